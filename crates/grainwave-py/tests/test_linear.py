"""Linear analysis from Python: the dynamical matrix, its modes and the moduli, checked against
closed forms and a second method."""

import math

import numpy as np
import pytest

import grainwave
import grainwave.linear as gl

K = 1.0e3  # Hooke normal stiffness k_n
KT = 0.25 * K  # tangential stiffness k_t
A = 0.98  # lattice spacing < diameter 1: every nearest-neighbour pair overlaps by 0.02
NX, NY = 6, 6


def lattice():
    """A periodic triangular lattice of equal disks, uniformly compressed: every site is a centre
    of inversion, so the state is static, no grain moves under a homogeneous strain and the
    relaxed moduli are the affine ones."""
    return {
        "experiment": "simulation",
        "seed": 1,
        "grains": {"kind": "disk", "count": NX * NY, "density": 1.0, "size": {"distribution": "monodisperse", "radius": 0.5}},
        "domain": {"size": [NX * A, NY * A * math.sqrt(3) / 2], "periodic": ["x", "y"]},
        # the lattice fills the region row by row from its corner plus a radius: rows of NX
        # sites starting at x = 0 (odd rows shifted by A/2), NY rows starting at y = 0
        "placement": {
            "method": "lattice",
            "spacing": A,
            "region_min": [-0.5, -0.5],
            "region_max": [(NX - 0.25) * A + 0.5, (NY - 0.5) * A * math.sqrt(3) / 2 + 0.5],
        },
        "contact": {"preset": "hooke_cundall_strack", "normal_stiffness": K, "tangential_stiffness_ratio": KT / K, "restitution": 0.5, "friction": 0.5},
        "integration": {"max_initial_overlap": 0.05},  # ξ = 0.02 = 0.04 R by construction
        "stop": {"step_limit": 1},
    }


@pytest.fixture
def sim():
    s = grainwave.Simulation(lattice())
    c = s.contacts()
    if c["i"].size != 3 * NX * NY:
        pytest.fail(f"the lattice placement gave {c['i'].size} contacts, {3 * NX * NY} expected (6 per grain)")
    return s


def test_moduli_of_the_triangular_lattice_are_the_closed_form(sim):
    m = gl.moduli(sim)
    c = m["voigt"]
    # Bonds of length a along the six unit vectors n (t ⟂ n), each with springs k_n along n and
    # k_t along t; the cell of one grain has area √3a²/2. Under a homogeneous strain the bond
    # stretches by a n·ε·n and slides by a t·ε·n (no grain relaxes: the rotations cancel since
    # Σ n_x n_y = Σ (n_x² − n_y²) = 0 over the bonds), so W/V = ½ εᵀCε with
    #   C11 = C22 = (9k_n/4 + 3k_t/4)/√3,  C12 = (3k_n/4 − 3k_t/4)/√3,  C33 = √3(k_n + k_t)/4
    # (sums over the bonds: Σ n_x⁴ = 9/4, Σ n_x²n_y² = 3/4, Σ (n_x² − n_y²)² = 3).
    r3 = math.sqrt(3)
    np.testing.assert_allclose([c[0][0], c[1][1]], (9 * K / 4 + 3 * KT / 4) / r3, rtol=1e-9)
    np.testing.assert_allclose(c[0][1], (3 * K / 4 - 3 * KT / 4) / r3, rtol=1e-9)
    np.testing.assert_allclose(c[2][2], r3 * (K + KT) / 4, rtol=1e-9)
    np.testing.assert_allclose(c[0][2], 0.0, atol=1e-9 * K)
    np.testing.assert_allclose(m["affine"], c, rtol=1e-9, atol=1e-9 * K)


def test_modes_solve_the_eigenproblem_of_the_matrix(sim):
    d = gl.dynamical_matrix(sim, sparse=False)
    dense = gl.to_dense(d)
    n = d["shape"][0]
    assert n == 3 * NX * NY and d["dofs_per_grain"] == 3 and d["symmetric"]
    np.testing.assert_allclose(dense, dense.T, atol=1e-12 * K)
    modes = gl.modes(sim)
    w2 = modes["omega_squared"]
    v = modes["vectors"]
    free = modes["free_dofs"]
    sub = dense[np.ix_(free, free)]
    mass = d["mass"][free]
    # residual D v = ω² M v of every mode, and a second method: NumPy's symmetric eigensolver
    # on M^-1/2 D M^-1/2
    np.testing.assert_allclose(sub @ v, (mass[:, None] * v) * w2[None, :], atol=1e-8 * K)
    s = 1 / np.sqrt(mass)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(s[:, None] * sub * s[None, :])), w2, atol=1e-8 * K)
    # two rigid translations of the periodic packing are zero modes
    assert np.sum(np.abs(w2) < 1e-9 * K) >= 2


def test_bad_options_are_named():
    s = grainwave.Simulation(lattice())
    with pytest.raises(ValueError, match=r'prestress = "some" \(allowed: "none", "normal", "full"\)'):
        gl.moduli(s, prestress="some")
    with pytest.raises(ValueError, match="rattlers"):
        gl.modes(s, rattlers="drop")


def test_modal_and_direct_pulses_agree(settle):
    # a settling pile (floor = wall 0, side walls 1 and 2): the kick of the floor seen on the
    # right wall, by the mode sum and by direct integration — two independent methods
    s = grainwave.Simulation(settle)
    s.step(12000)
    t = np.linspace(0.0, 0.5, 51)
    modal = gl.modal_pulse(s, 0, 2, t)
    direct = gl.direct_pulse(s, 0, 2, t, steps_per_period=40.0)
    np.testing.assert_array_equal(modal["times"], t)
    scale = np.abs(modal["signal"]).max()
    assert scale > 0 and modal["signal"][0] == 0.0  # an impulse moves nothing at t = 0
    # the 4th-order scheme at 40 steps per shortest period: relative error ≲ 1e-5
    np.testing.assert_allclose(direct["signal"], modal["signal"], rtol=0, atol=1e-5 * scale)
    with pytest.raises(ValueError, match=r"times: entry \[2\] = 0.1 is before entry \[1\] = 0.2"):
        gl.modal_pulse(s, 0, 2, [0.0, 0.2, 0.1])
    with pytest.raises(ValueError, match="wall index 7"):
        gl.modal_pulse(s, 0, 7, t)


@pytest.fixture
def pile(settle):
    """The settled frictional pile of the pulse test above (floor = wall 0, sides 1 and 2): some
    of its contacts are at the Coulomb limit."""
    s = grainwave.Simulation(settle)
    s.step(12000)
    return s


def test_incremental_pulse_is_positively_homogeneous(pile):
    t = np.linspace(0.0, 1.0, 101)
    one = gl.incremental_pulse(pile, 0, t, amplitude=1.0, detector_wall=2)
    counts = one["counts"]
    assert counts["contacts"] > 0
    if counts["at_limit"] == 0:
        pytest.fail(f"the pile has no contact at the Coulomb limit ({counts}): the test would not test the branch rule")
    assert one["history"]["contact"].size >= counts["at_limit"]
    assert one["velocity"].shape == (t.size, one["grain_ids"].size, 2)
    assert np.abs(one["velocity"]).max() > 0 and np.abs(one["signal"]).max() > 0
    # degree one: a power of two scales every operation exactly, branch decisions included
    two = gl.incremental_pulse(pile, 0, t, amplitude=2.0, detector_wall=2)
    np.testing.assert_array_equal(two["velocity"], 2.0 * one["velocity"])
    np.testing.assert_array_equal(two["signal"], 2.0 * one["signal"])
    np.testing.assert_array_equal(two["history"]["slip_steps"], one["history"]["slip_steps"])
    # ... but not odd: the other sign pushes other contacts on, so −1 is not −(+1)
    minus = gl.incremental_pulse(pile, 0, t, amplitude=-1.0, detector_wall=2)
    assert one["counts"]["slipped"] + minus["counts"]["slipped"] > 0
    scale = np.abs(one["velocity"]).max()
    assert np.abs(minus["velocity"] + one["velocity"]).max() > 1e-6 * scale
    assert not np.array_equal(minus["history"]["slip_steps"], one["history"]["slip_steps"])
    # with every contact sticking the network is linear: −1 is exactly −(+1), and never slips
    stick = gl.incremental_pulse(pile, 0, t, amplitude=1.0, branches="stick", detector_wall=2)
    stick_minus = gl.incremental_pulse(pile, 0, t, amplitude=-1.0, branches="stick", detector_wall=2)
    np.testing.assert_array_equal(stick_minus["velocity"], -stick["velocity"])
    assert stick["counts"]["slipped"] == 0 and stick["slipping"].max() == 0
    # the amplitude-independent numbers agree between the amplitudes
    assert one["steps"] == two["steps"] == minus["steps"] and one["max_step"] == minus["max_step"]


def test_incremental_pulse_without_slip_is_the_linear_pulse(pile):
    # "stick" (and "free") are the bilateral networks of sliding = "stick" ("free"): the force on
    # the right wall after the floor's kick, against the exact mode sum of the same network (an
    # independent method: eigenvectors, no time stepping). The incremental integrator is velocity
    # Verlet (2nd order), so the difference falls by ≈ 4 when the steps per period double.
    t = np.linspace(0.0, 0.5, 51)
    for rule in ("stick", "free"):
        modal = gl.modal_pulse(pile, 0, 2, t, sliding=rule)
        scale = np.abs(modal["signal"]).max()
        assert scale > 0
        errors = []
        for spp in (200.0, 400.0):
            inc = gl.incremental_pulse(pile, 0, t, branches=rule, detector_wall=2, wall_damping=False, steps_per_period=spp)
            errors.append(np.abs(inc["signal"] - modal["signal"]).max() / scale)
        assert errors[1] < 2e-3, (rule, errors)
        assert 3.0 < errors[0] / errors[1] < 5.0, (rule, errors)


def test_incremental_pulse_of_a_piston_and_by_duration(pile):
    # the floor as a piston of mass M = 5 kicked by the impulse 1: it starts at 1/M and obeys
    # M q̈ = −F_sig with F_sig its own normal load increment (the detector signal of the same
    # wall, which counts its displacement q) — checked by the trapezoid rule between samples
    # (34 per shortest period: error ≈ 4e-4 of the largest change)
    mass = 5.0
    a = gl.incremental_pulse(pile, 0, duration=0.2, sample_interval=0.0005, piston_mass=mass, detector_wall=0)
    t, f, q, qdot = a["times"], a["signal"], a["piston_displacement"], a["piston_velocity"]
    assert t.size == 401 and t[-1] == pytest.approx(0.2)
    assert qdot[0] == 1.0 / mass and q[0] == 0.0
    dv = np.diff(qdot)
    np.testing.assert_allclose(dv, -0.5 * (f[1:] + f[:-1]) * np.diff(t) / mass, rtol=0, atol=5e-3 * np.abs(dv).max())
    dq = np.diff(q)
    np.testing.assert_allclose(dq, 0.5 * (qdot[1:] + qdot[:-1]) * np.diff(t), rtol=0, atol=5e-3 * np.abs(dq).max())
    # the samples by duration are those by times
    b = gl.incremental_pulse(pile, 0, t, piston_mass=mass, detector_wall=0)
    np.testing.assert_array_equal(b["velocity"], a["velocity"])
    assert a["steps"] > 0 and a["wall_seconds"] >= 0.0


def test_incremental_pulse_bad_arguments_are_named(pile):
    t = [0.0, 0.1]
    cases = [
        (dict(branches="slide"), r'branches = "slide" \(allowed: "incremental", "stick", "free", "slip"\)'),
        (dict(amplitude=float("nan")), r"amplitude = NaN \(allowed: a finite number\)"),
        (dict(piston_mass=-1.0), r'piston_mass = -1 \(allowed: None, "state" or a finite mass > 0\)'),
        (dict(piston_mass="wall"), r'piston_mass = "wall"'),
        (dict(piston_mass="state"), r'piston_mass = "state": the wall 0'),
        (dict(detector_wall=3), r"detector_wall = 3 \(allowed: a wall index 0 to 2"),
        (dict(steps_per_period=3.0), r"steps_per_period = 3 \(allowed: a number > π"),
        (dict(mobilisation_tolerance=1.0), r"mobilisation_tolerance = 1 \(allowed: a number in \[0, 1\)"),
        (dict(strips=0), r"strips = 0 \(allowed: an integer ≥ 1\)"),
        (dict(fit_range=(0.9, 0.1)), r"fit_range = \(0.9, 0.1\)"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            gl.incremental_pulse(pile, 0, t, **kwargs)
    with pytest.raises(ValueError, match=r"wall = 5 \(allowed: a wall index 0 to 2"):
        gl.incremental_pulse(pile, 5, t)
    with pytest.raises(ValueError, match=r"times: entry \[0\] = -0.1 is before the pulse"):
        gl.incremental_pulse(pile, 0, [-0.1, 0.0])
    with pytest.raises(ValueError, match=r"times = None"):
        gl.incremental_pulse(pile, 0)
    with pytest.raises(ValueError, match=r"sample_interval = 0"):
        gl.incremental_pulse(pile, 0, duration=1.0, sample_interval=0)
    with pytest.raises(ValueError, match=r"duration = 1.0, sample_interval = None \(allowed: None when times is given\)"):
        gl.incremental_pulse(pile, 0, t, duration=1.0)
