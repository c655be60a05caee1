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

:func:`incremental_pulse` is the piecewise-linear network of ``grainwave_linear::incremental``
instead: contacts at the Coulomb limit slip or stick by the sign of the increment (docs/python.md,
"Incremental pulses").
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional, Sequence, Union

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


def _number(x) -> Optional[float]:
    """``x`` as a float, None when it is not a real number."""
    if isinstance(x, (bool, str, bytes)):
        return None
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def incremental_pulse(
    sim,
    wall: int,
    times=None,
    amplitude: float = 1.0,
    branches: str = "incremental",
    piston_mass: Union[None, float, str] = None,
    detector_wall: Optional[int] = None,
    rolling_cap: bool = True,
    wall_damping: bool = True,
    mobilisation_tolerance: float = 1e-6,
    steps_per_period: float = 50.0,
    strips: int = 128,
    fit_range: Sequence[float] = (0.1, 0.9),
    duration: Optional[float] = None,
    sample_interval: Optional[float] = None,
) -> Dict[str, Any]:
    """The δ pulse of wall ``wall`` through the incremental (piecewise-linear) network of the
    current state: every contact linearized, those at the Coulomb limit (|F_t| ≥ (1 −
    ``mobilisation_tolerance``) μ F_n) following ``branches``: "incremental" (slip while the
    increment pushes them on, stick once it unloads them), "stick", "free" (no tangential
    stiffness) or "slip" (the slip branch both ways). Velocity Verlet with ``steps_per_period``
    steps per shortest period; contact dashpots left out, constant wall dashpots kept when
    ``wall_damping``.

    The pulse at t = 0: with ``piston_mass`` None the walls stay fixed and the grains touching
    ``wall`` get the impulse ``amplitude`` × s_i of :func:`direct_pulse`'s "impulse" condition
    (``amplitude`` = h, length × time); with a mass (or "state": the wall's piston mass in the
    simulation) the wall moves as a piston of that mass with the initial velocity ``amplitude``
    / mass along its inward normal (``amplitude`` = the impulse, force × time). A positive
    amplitude compresses. The response is positively homogeneous of degree one: +1 and −1 are
    the exact small-amplitude limits of the two signs.

    Samples at ``times`` (increasing, ≥ 0), or every ``sample_interval`` from 0 to ``duration``.
    Returns ``times``; ``velocity`` (samples × grains × d, the grains' translational velocities
    in the order of ``grain_ids``); ``positions`` and ``distance`` (from the wall) of the grains;
    ``arrival`` (per grain, the sample time of the largest |v·n̂| along the wall's normal, NaN when
    it never moves or peaks at the last sample) and ``fit`` (the strip fit of the E2 analysis:
    ``strips`` strips, the third-earliest grain of each, centres within ``fit_range`` of the
    largest distance; dict with ``speed``, ``intercept``, ``strips_used``, ``distance``,
    ``time``; None when fewer than two strips or no positive speed); ``signal`` (the normal force
    increment on ``detector_wall``, None without one); ``piston_displacement`` and
    ``piston_velocity`` (None without a piston); ``slipping`` (contacts on the tangential slip
    branch at each sample); ``counts`` (contacts, at_limit, at_rolling_cap, nearly_open_1e6, nearly_open_1e3,
    mean_normal_force, unloaded, slipped); ``history`` (per contact at the limit: ``contact``,
    grain ids ``i``, ``j`` (−1 − wall index for a wall), ``slip_steps``, ``switches``,
    ``first_slip``, ``last_switch`` (NaN: never), ``slipping`` at the end); ``branches``,
    ``steps``, ``max_step``, ``wall_seconds``."""
    if times is None:
        if duration is None or sample_interval is None:
            raise ValueError("times = None (allowed: an increasing sequence of times ≥ 0, or duration and sample_interval both given)")
        length, interval = _number(duration), _number(sample_interval)
        if not (length is not None and math.isfinite(length) and length >= 0):
            raise ValueError(f"duration = {duration!r} (allowed: a finite time ≥ 0)")
        if not (interval is not None and math.isfinite(interval) and interval > 0):
            raise ValueError(f"sample_interval = {sample_interval!r} (allowed: a finite time > 0)")
        times = interval * np.arange(int(math.floor(length / interval * (1 + 1e-12))) + 1)
    elif duration is not None or sample_interval is not None:
        raise ValueError(f"duration = {duration!r}, sample_interval = {sample_interval!r} (allowed: None when times is given)")
    fr = tuple(fit_range)
    if len(fr) != 2:
        raise ValueError(f"fit_range = {fit_range!r} (allowed: two fractions 0 ≤ a < b ≤ 1)")
    return _native.incremental_pulse(sim, wall, times, amplitude, branches, piston_mass, detector_wall, rolling_cap, wall_damping, mobilisation_tolerance, steps_per_period, strips, fr)
