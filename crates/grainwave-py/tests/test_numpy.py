"""Simulations in the NumPy world: read-only arrays, tables with their dtypes, contact records
as flat rows (records, pandas), copies and pickles, progress of step and run_until, and the
papercuts of stepping (negative counts, the step limit's origin, forces under damping)."""

import copy
import pickle
import sys

import numpy as np
import pytest

import grainwave
from conftest import contact_force_sum


def test_per_grain_arrays_refuse_assignment(settle):
    sim = grainwave.Simulation(settle)
    for name in ("positions", "velocities", "forces", "angular_velocities", "torques", "radii", "masses", "inertias", "ids"):
        a = getattr(sim, name)
        assert not a.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 1
    # before: `sim.positions[0] = …` changed a copy and nothing else; a writable copy is explicit
    x = sim.positions.copy()
    x[0, 0] += 0.01
    sim.set_positions(x)
    assert sim.positions[0, 0] == x[0, 0]
    # the contact records are a new dict at every call: writable
    c = sim.contacts()
    assert all(v.flags.writeable for v in c.values())


def test_step_refuses_a_negative_count_with_a_value_error(settle):
    sim = grainwave.Simulation(settle)
    for bad in (-1, 2.5, "3", True, 2**64):
        with pytest.raises((ValueError, TypeError)) as info:
            sim.step(bad)
        assert not isinstance(info.value, OverflowError)
        assert "allowed: a whole number of steps ≥ 0" in str(info.value) and repr(bad) in str(info.value), str(info.value)
    with pytest.raises(ValueError, match=r"step_limit = -5 \(allowed: a whole number of steps"):
        sim.run_until(step_limit=-5)
    sim.step(0)
    sim.step(np.int64(3))
    sim.step()
    assert sim.step_count == 4


def test_run_until_step_limit_counts_from_step_zero(settle):
    sim = grainwave.Simulation(settle)
    sim.step(700)
    assert sim.run_until(step_limit=1000) == {"reason": "step_limit", "steps": 300}
    assert sim.step_count == 1000
    # a limit already passed: no step
    assert sim.run_until(step_limit=900) == {"reason": "step_limit", "steps": 0}
    doc = grainwave.Simulation.run_until.__doc__
    assert "counted from its start" in doc and "makes 300 steps" in doc


def test_forces_are_those_of_the_half_step_velocities_under_damping(settle):
    # documented on `forces`: under damping (restitution 0.5: contact dashpots) they differ from
    # the sum of the contact records, which use the current velocities, until the forces are
    # recomputed at the current velocities
    sim = grainwave.Simulation(settle)
    sim.step(4000)  # grains landed and still moving: the dashpots act
    assert sim.contacts()["i"].size > 0

    total, scale = contact_force_sum(sim)
    assert np.abs(sim.forces - total).max() > 1e-6 * scale
    assert "half-step velocities" in grainwave.Simulation.forces.__doc__
    sim.set_velocities(sim.velocities)
    sim.set_angular_velocities(sim.angular_velocities)
    total, scale = contact_force_sum(sim)
    np.testing.assert_allclose(sim.forces, total, rtol=0, atol=1e-9 * scale)


def test_copy_is_deep_and_continues_to_the_same_bits(settle):
    a = grainwave.Simulation(settle)
    a.step(500)
    b = a.copy()
    assert b.state_hash == a.state_hash
    b.step(1000)
    assert a.step_count == 500 and b.step_count == 1500  # independent
    a.step(1000)
    assert a.state_hash == b.state_hash
    np.testing.assert_array_equal(a.positions, b.positions)
    for c in (copy.copy(a), copy.deepcopy(a), pickle.loads(pickle.dumps(a))):
        assert c.state_hash == a.state_hash
        c.step(100)
        assert c.step_count == 1600 and a.step_count == 1500
    # the copy keeps the config's stop criteria (run_until() without arguments)
    assert a.copy().run_until() == {"reason": "step_limit", "steps": 1500}


def test_contact_records_as_rows(settle):
    sim = grainwave.Simulation(settle)
    sim.step(8000)
    c = sim.contacts()
    assert isinstance(c, dict) and isinstance(c, grainwave.Columns)
    r = c.records()
    m = c["i"].size
    assert m > 0 and r.shape == (m,)
    assert r.dtype["i"] == np.int64 and r.dtype["sliding"] == np.bool_ and r.dtype["normal_x"] == np.float64
    np.testing.assert_array_equal(r["normal_y"], c["normal"][:, 1])
    np.testing.assert_array_equal(r["tangential_force_x"], c["tangential_force"][:, 0])
    assert "normal" not in r.dtype.names


def test_to_pandas_without_pandas_says_how_to_install_it(settle, monkeypatch):
    c = grainwave.Simulation(settle).contacts()
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if not installed
    with pytest.raises(ImportError, match=r"pip install pandas"):
        c.to_pandas()


def test_to_pandas_gives_flat_columns(tmp_path, settle):
    pd = pytest.importorskip("pandas", reason="skipped: pandas not available (pip install pandas)")
    sim = grainwave.Simulation(settle)
    sim.step(8000)
    df = sim.contacts().to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == sim.contacts()["i"].size
    assert df["i"].dtype == np.int64 and "normal_x" in df.columns
    settle["stop"]["step_limit"] = 100
    t = grainwave.run(settle, out=tmp_path / "run", threads=1).tables["grains"].to_pandas()
    assert len(t) == 40


def test_integer_columns_are_integers(tmp_path, settle):
    p = tmp_path / "t.csv"
    p.write_text("seed,grains,steps,x,gap\n1,25,26640.0,1.5,\n2,-3,100.0,2,4\n")
    t = grainwave.read_table(p)
    assert t["seed"].dtype == np.int64 and t["seed"].tolist() == [1, 2]
    assert t["grains"].dtype == np.int64 and t["grains"].tolist() == [25, -3]
    # written as floats (a point), a mix, or with an empty field: float64
    assert t["steps"].dtype == np.float64 and t["x"].dtype == np.float64 and t["gap"].dtype == np.float64
    settle["stop"]["step_limit"] = 1000
    r = grainwave.run(settle, out=tmp_path / "run", threads=1)
    grains = r.tables["grains"]
    assert grains["id"].dtype == np.int64
    np.testing.assert_array_equal(grains["id"], np.arange(40))
    assert grains["x"].dtype == np.float64
    # the time series writes its counts as integers (`500`), its measurements as floats, in the
    # CSV and in the archive alike
    for name in ("step", "contacts", "sliding"):
        assert r.tables["series"][name].dtype == np.int64, name
        assert r.arrays["series"][name].dtype == np.int64, name
    assert r.tables["series"]["time"].dtype == np.float64 and r.arrays["series"]["time"].dtype == np.float64
    np.testing.assert_array_equal(r.tables["series"]["step"], r.arrays["series"]["step"])


def test_progress_of_step_and_run_until(settle):
    sim = grainwave.Simulation(settle)
    events = []
    sim.step(2500, progress=events.append)
    stage = events[0]
    assert stage == {"kind": "stage", "name": "step", "total_steps": 2500, "first_step": 0}
    steps = [e["step"] for e in events if e["kind"] == "progress"]
    assert steps == [1000, 2000, 2500]
    plain = grainwave.Simulation(settle)
    plain.step(2500)
    assert plain.state_hash == sim.state_hash  # progress changes no bit
    events.clear()
    assert sim.run_until(step_limit=6000, progress=events.append) == {"reason": "step_limit", "steps": 3500}
    assert events[0]["name"] == "run_until" and events[0]["total_steps"] == 6000 and events[0]["first_step"] == 2500
    steps = [e["step"] for e in events if e["kind"] == "progress"]
    assert steps and steps == sorted(steps) and steps[-1] == 6000
    plain.run_until(step_limit=6000)
    assert plain.state_hash == sim.state_hash
    # an equilibrium criterion may end the run before the limit: no total (no false ETA)
    events.clear()
    sim.run_until(step_limit=7000, kinetic_energy_per_grain=1e-30, check_every=100, progress=events.append)
    assert events[0]["total_steps"] is None
    # a bar (tqdm, or lines on stderr) works without a terminal
    sim.step(10, progress=True)
    sim.run_until(step_limit=sim.step_count + 10, progress=True)


def test_an_exception_of_the_progress_callback_stops_after_a_whole_step(settle):
    sim = grainwave.Simulation(settle)

    def fail(event):
        if event["kind"] == "progress":
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        sim.run_until(step_limit=50_000, progress=fail)
    n = sim.step_count
    assert 0 < n < 50_000
    plain = grainwave.Simulation(settle)
    plain.step(n)
    assert plain.state_hash == sim.state_hash


class _Bar:
    """A stand-in for tqdm that records what a bar was asked to show."""

    made = []

    def __init__(self, total=None, desc=None, **kwargs):
        self.total, self.desc, self.n = total, desc, 0
        _Bar.made.append(self)

    def update(self, k):
        self.n += k

    def set_postfix(self, **kwargs):
        pass

    def set_description(self, desc, refresh=True):
        self.desc = desc

    def close(self):
        pass

    @staticmethod
    def write(text):
        pass


def test_progress_bars_show_what_the_run_reports(tmp_path, settle):
    from grainwave import _progress
    from test_errors import E1

    # a study that counts units only (E1): no step bar stuck at 0, the units bar named by the stage
    _Bar.made = []
    bars = _progress._Tqdm(_Bar)
    grainwave.run(E1, out=tmp_path / "e1", threads=1, progress=bars)
    bars.close()
    assert len(_Bar.made) == 1
    units = _Bar.made[0]
    assert units.desc.startswith("samples") and units.total == units.n == 1
    # a simulation: a step bar from the step count it starts at to its limit
    _Bar.made = []
    bars = _progress._Tqdm(_Bar)
    sim = grainwave.Simulation(settle)
    sim.step(500)
    sim.run_until(step_limit=3000, progress=bars)
    bars.close()
    (steps,) = _Bar.made
    assert steps.desc == "run_until" and steps.total == 2500 and steps.n == 2500


def test_ctrl_c_stops_run_until_after_a_whole_step(settle):
    import os
    import signal

    sim = grainwave.Simulation(settle)
    sent = []

    def press_ctrl_c(event):
        # the signal Ctrl-C sends, delivered while the run goes on
        if event["kind"] == "progress" and not sent:
            sent.append(event["step"])
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        sim.run_until(step_limit=200_000, progress=press_ctrl_c)
    n = sim.step_count
    assert sent and 0 < n < 200_000
    # a whole number of steps: the same bits as n steps, and it continues like an uncut run
    plain = grainwave.Simulation(settle)
    plain.step(n)
    assert plain.state_hash == sim.state_hash
    sim.run_until(step_limit=n + 1000)
    plain.run_until(step_limit=n + 1000)
    assert plain.state_hash == sim.state_hash
