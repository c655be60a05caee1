"""Linear analysis of a simulation's current state (``grainwave-linear``, docs/linear.md).

Around the current positions every contact is replaced by its stiffnesses (k_n, k_t and the
lever arms that couple rotations), and small motions obey M ü = −D u. The degrees of freedom go
grain by grain in the order of ``grain_ids``, each grain its d translations then its rotations
(1 in 2D, 3 in 3D). Options (as in the E1 config's linear keys):

* ``prestress``: "none" (D = Σ Gᵀ K G, symmetric, positive semi-definite), "normal" (plus the
  geometric term −F_n/|r| of SPEC §5.4), "full" (the exact Jacobian, not symmetric);
* ``rattlers``: "keep" or "remove" (grains with fewer force-carrying contacts than needed);
* ``sliding``: "stick" (keep k_t of sliding contacts) or "free" (k_t = 0 there);
* ``rolling``: include rolling/twisting springs when the contact law has them.
"""

from __future__ import annotations

from typing import Any, Dict

import numpy as np

from . import _native


def dynamical_matrix(sim, prestress: str = "none", rattlers: str = "keep", sliding: str = "stick", rolling: bool = True, sparse: Any = None) -> Dict[str, Any]:
    """D as COO triplets (``rows``, ``cols``, ``values``, ``shape``) with the diagonal of M
    (``mass``), ``grain_ids``, ``dofs_per_grain``, ``removed`` (rattlers) and ``symmetric``.
    With ``sparse`` True (default: when SciPy is installed) also ``matrix``, a
    ``scipy.sparse.csr_matrix``."""
    d = _native.dynamical_matrix(sim, prestress, rattlers, sliding, rolling)
    if sparse is None or sparse:
        try:
            from scipy.sparse import csr_matrix
        except ImportError:
            if sparse:
                raise
        else:
            d["matrix"] = csr_matrix((d["values"], (d["rows"], d["cols"])), shape=d["shape"])
    return d


def to_dense(d: Dict[str, Any]) -> np.ndarray:
    """The dense D of a :func:`dynamical_matrix` result (small systems)."""
    a = np.zeros(d["shape"])
    np.add.at(a, (d["rows"], d["cols"]), d["values"])
    return a


def modes(sim, prestress: str = "none", rattlers: str = "keep", sliding: str = "stick", rolling: bool = True, threads: int = 1) -> Dict[str, Any]:
    """Every eigenmode D v = ω² M v (dense decomposition): ``omega_squared`` (ascending),
    ``frequencies`` ω, ``vectors`` (free dofs × modes, M-orthonormal), ``participation``,
    ``free_dofs`` (the rows of ``vectors`` among all dofs), ``mass``, ``grain_ids``,
    ``dofs_per_grain``. ``threads``: threads of the eigensolver (the modes are the same bits
    only at a fixed count)."""
    return _native.modes(sim, prestress, rattlers, sliding, rolling, threads)


def moduli(sim, prestress: str = "none", rattlers: str = "keep", sliding: str = "stick", rolling: bool = True) -> Dict[str, Any]:
    """Elastic moduli by imposed strain and linear relaxation (SPEC §5.3): ``voigt`` (relaxed C,
    3 × 3 in 2D — C₁₁ = C[0][0], C₁₂ = C[0][1], C₂₂ = C[1][1], C₃₃ = C[2][2] — or 6 × 6 in 3D),
    ``affine`` (no relaxation, an upper bound), ``volume``, ``density``,
    ``longitudinal_speed``, ``transverse_speed``, ``asymmetry`` (a check of the solves)."""
    d = _native.moduli(sim, prestress, rattlers, sliding, rolling)
    d["voigt"] = np.asarray(d["voigt"])
    d["affine"] = np.asarray(d["affine"])
    return d


def modal_pulse(sim, source_wall: int, detector_wall: int, times, initial_condition: str = "impulse", strength: float = 1.0, prestress: str = "none", rattlers: str = "keep", sliding: str = "stick", rolling: bool = True, threads: int = 1) -> Dict[str, Any]:
    """The pulse of SPEC §5.5 as a sum over all modes: ``signal`` F_sig(t) on the detector wall
    at ``times`` (increasing) after the source wall's kick (``initial_condition`` "impulse", A,
    strength h) or displacement ("displacement", B, amplitude δ); grains free, walls fixed (wall
    indices in the order of the config's ``[[walls]]``). Also ``omega_squared``,
    ``participation``, ``contributions`` a_n b_n, ``coupling`` b_n, ``dofs``."""
    return _native.modal_pulse(sim, source_wall, detector_wall, times, initial_condition, strength, prestress, rattlers, sliding, rolling, threads)


def direct_pulse(sim, source_wall: int, detector_wall: int, times, initial_condition: str = "impulse", strength: float = 1.0, prestress: str = "none", rattlers: str = "keep", sliding: str = "stick", rolling: bool = True, steps_per_period: float = 20.0) -> Dict[str, Any]:
    """The same pulse by direct integration of M ü = −D u with a 4th-order symplectic scheme
    (``steps_per_period`` steps per shortest period): ``signal``, ``steps``, ``max_step``."""
    return _native.direct_pulse(sim, source_wall, detector_wall, times, initial_condition, strength, prestress, rattlers, sliding, rolling, steps_per_period)
