"""Simulations stepped from Python: arrays, contact records, setting state, checkpoints, and the
same bits as the command line."""

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

import grainwave
from grainwave import _config
from conftest import contact_force_sum


def test_arrays_have_the_shapes_and_values_of_the_grains(settle):
    sim = grainwave.Simulation(settle)
    n = len(sim)
    assert n == 40 and sim.dimension == 2 and sim.grain_kind == "disk" and sim.step_count == 0
    np.testing.assert_array_equal(sim.ids, np.arange(n))
    for name in ("positions", "velocities", "forces"):
        assert getattr(sim, name).shape == (n, 2), name
    for name in ("radii", "masses", "inertias", "angular_velocities", "torques"):
        assert getattr(sim, name).shape == (n,), name
    r, m = sim.radii, sim.masses
    # disks of density 1 per unit area: m = ρ π R², I = m R² / 2 (closed forms)
    np.testing.assert_allclose(m, math.pi * r**2, rtol=1e-14)
    np.testing.assert_allclose(sim.inertias, 0.5 * m * r**2, rtol=1e-14)
    # diameters uniform in [0.8, 1.2] (mean 1, spread 0.2)
    assert np.all((2 * r >= 0.8) & (2 * r <= 1.2))


def test_free_flight_follows_the_closed_form(settle):
    # grains placed as a gas touch nothing at first: one velocity-Verlet step under gravity g
    # moves each by v dt + g dt²/2 exactly (up to rounding), which also checks that positions,
    # velocities and the values set are in the same (id) order
    sim = grainwave.Simulation(settle)
    assert sim.contacts()["i"].size == 0
    rng = np.random.default_rng(1)
    v = rng.normal(size=(len(sim), 2)) * 1e-3
    sim.set_velocities(v)
    np.testing.assert_array_equal(sim.velocities, v)
    ke = 0.5 * np.sum(sim.masses[:, None] * v**2)
    assert sim.kinetic_energy == pytest.approx(ke, rel=1e-12)
    x0, dt = sim.positions, sim.dt
    sim.step()
    g = np.array([0.0, -1.0])
    np.testing.assert_allclose(sim.positions, x0 + v * dt + 0.5 * g * dt**2, rtol=0, atol=1e-13)
    np.testing.assert_allclose(sim.velocities, v + g * dt, rtol=0, atol=1e-13)
    assert sim.step_count == 1 and sim.time == pytest.approx(dt)


def test_contact_records_balance_the_forces(settle):
    sim = grainwave.Simulation(settle)
    sim.step(12000)
    # the records are evaluated at the current velocities, `forces` at the last force evaluation
    # (velocity Verlet: damping at the half-step velocities); setting the velocities recomputes
    # the forces at the state the records see
    sim.set_velocities(sim.velocities)
    sim.set_angular_velocities(sim.angular_velocities)
    c = sim.contacts()
    m = c["i"].size
    assert m > 20
    for k in ("j", "wall", "overlap", "normal_force", "normal_stiffness", "tangential_stiffness", "sliding"):
        assert c[k].shape == (m,), k
    for k in ("normal", "branch", "tangential_force"):
        assert c[k].shape == (m, 2), k
    assert np.all((c["j"] >= 0) != (c["wall"] >= 0))
    assert np.all(c["overlap"] > 0) and np.all(c["normal_force"] >= 0)
    np.testing.assert_allclose(np.linalg.norm(c["normal"], axis=1), 1.0, rtol=1e-12)
    # Newton's third law and the records: the force on each grain is the sum over its contacts
    # (−F_n n̂ + F_t on i, the opposite on j) plus its weight
    total, scale = contact_force_sum(sim)
    np.testing.assert_allclose(sim.forces, total, rtol=0, atol=1e-9 * scale)


def test_step_n_is_n_steps_of_one(settle):
    a, b = grainwave.Simulation(settle), grainwave.Simulation(settle)
    a.step(2500)
    for _ in range(2500):
        b.step(1)
    assert a.state_hash == b.state_hash
    np.testing.assert_array_equal(a.positions, b.positions)


def test_the_state_is_the_command_line_state_bit_for_bit(tmp_path, settle, cli):
    config = tmp_path / "settle.toml"
    config.write_text(_config.dumps(settle))
    subprocess.run([cli, "--quiet", "--threads", "1", "run", str(config), "--out", str(tmp_path / "cli")], check=True)
    theirs = grainwave.Simulation.load(tmp_path / "cli")
    ours = grainwave.Simulation(config)
    ours.step(3000)
    assert theirs.step_count == ours.step_count == 3000
    assert theirs.state_hash == ours.state_hash
    for name in ("positions", "velocities", "angular_velocities", "forces", "torques"):
        np.testing.assert_array_equal(getattr(theirs, name), getattr(ours, name), err_msg=name)
    # the VTK snapshots of that state: the run's final snapshot, byte for byte
    grains, contacts = ours.write_snapshot(tmp_path / "py")
    for path in (grains, contacts):
        rel = Path(path).relative_to(tmp_path / "py")
        assert str(rel).startswith("snapshots/") and str(rel).endswith("_0000003000.vtp"), rel
        assert Path(path).read_bytes() == (tmp_path / "cli" / rel).read_bytes(), rel
    assert b'NumberOfPoints="40"' in Path(grains).read_bytes()
    assert len(ours.contacts()["i"]) > 0 and b"<PolyData>" in Path(contacts).read_bytes()


def test_save_and_load_continue_bit_for_bit(tmp_path, settle):
    sim = grainwave.Simulation(settle)
    sim.step(1000)
    sim.save(tmp_path / "a.gwck")
    back = grainwave.Simulation.load(tmp_path / "a.gwck")
    assert back.state_hash == sim.state_hash
    back.save(tmp_path / "b.gwck")
    assert (tmp_path / "a.gwck").read_bytes() == (tmp_path / "b.gwck").read_bytes()
    sim.step(1000)
    back.step(1000)
    assert back.state_hash == sim.state_hash
    np.testing.assert_array_equal(back.positions, sim.positions)


def test_bad_arrays_are_refused_with_the_reason_and_change_nothing(settle):
    sim = grainwave.Simulation(settle)
    before = sim.state_hash
    with pytest.raises(ValueError, match=r"positions: shape \(40, 3\) given, \(40, 2\) expected"):
        sim.set_positions(np.zeros((40, 3)))
    with pytest.raises(ValueError, match=r"velocities: shape \(39, 2\) given"):
        sim.set_velocities(np.zeros((39, 2)))
    bad = sim.positions.copy()  # the property is read-only
    bad[5, 1] = np.nan
    with pytest.raises(ValueError, match=r"positions: entry \[5, 1\] is NaN \(allowed: finite numbers\)"):
        sim.set_positions(bad)
    with pytest.raises(ValueError, match=r"angular_velocities: entry \[2\] is inf"):
        sim.set_angular_velocities(np.where(np.arange(40) == 2, np.inf, 0.0))
    with pytest.raises(ValueError, match="cannot be read as an array of numbers"):
        sim.set_velocities([["a", "b"]] * 40)
    assert sim.state_hash == before
    # lists are arrays too
    sim.set_velocities(np.zeros((40, 2)).tolist())


def test_set_positions_moves_grains_and_makes_contacts(settle):
    sim = grainwave.Simulation(settle)
    x = sim.positions.copy()  # the property is read-only
    r = sim.radii
    # put grain 1 against grain 0, overlapping by 1 % of the smaller radius
    x[1] = x[0] + np.array([r[0] + r[1] - 0.01 * min(r[0], r[1]), 0.0])
    sim.set_positions(x)
    np.testing.assert_array_equal(sim.positions[1], x[1])
    c = sim.contacts()
    k = np.flatnonzero((np.minimum(c["i"], c["j"]) == 0) & (np.maximum(c["i"], c["j"]) == 1))
    assert k.size == 1
    assert c["overlap"][k[0]] == pytest.approx(0.01 * min(r[0], r[1]), rel=1e-9)
    # linear law: F_n = k_n ξ at rest (no damping without relative velocity)
    assert c["normal_force"][k[0]] == pytest.approx(1.0e4 * c["overlap"][k[0]], rel=1e-9)


def test_external_forces_accelerate_the_grain(settle):
    sim = grainwave.Simulation(settle)
    f = np.zeros((40, 2))
    f[3] = [2.0, 5.0]
    sim.set_external_forces(f)
    m = sim.masses[3]
    np.testing.assert_allclose(sim.forces[3], [2.0, 5.0 - m], rtol=1e-14)
    with pytest.raises(ValueError, match=r"forces: shape \(2,\) given"):
        sim.set_external_forces([1.0, 2.0])


def test_run_until_uses_the_engine_stop_criteria(settle):
    sim = grainwave.Simulation(settle)
    out = sim.run_until(step_limit=700)
    assert out == {"reason": "step_limit", "steps": 700} and sim.step_count == 700
    t = sim.time + 50 * sim.dt
    assert sim.run_until(time_limit=t) == {"reason": "time_limit", "steps": 50}
    # the time is a sum of steps: it reaches the limit up to rounding
    assert sim.step_count == 750 and sim.time == pytest.approx(t, rel=1e-14)
    # without criteria: those of the config (step_limit 3000, an absolute step)
    left = 3000 - sim.step_count
    assert sim.run_until() == {"reason": "step_limit", "steps": left}
    assert sim.step_count == 3000
    with pytest.raises(ValueError, match="stop.time_limit"):
        sim.run_until(time_limit=-1.0)


def test_a_study_config_is_not_a_simulation():
    with pytest.raises(grainwave.ConfigError, match="a Simulation is built from") as info:
        grainwave.Simulation({"experiment": "e1"})
    assert info.value.key == "experiment"


def test_loading_what_is_not_a_checkpoint_is_refused(tmp_path):
    p = tmp_path / "x.gwck"
    p.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="x.gwck"):
        grainwave.Simulation.load(p)
    with pytest.raises(ValueError, match="no `checkpoint.gwck` there"):
        grainwave.Simulation.load(tmp_path)
