"""Studies from Python: check, run, resume, errors, progress, interrupt, and the same bits as the
command line."""

import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest

import grainwave
from grainwave import _config
from conftest import dir_files


def test_check_describes_a_valid_config(settle):
    lines = grainwave.check(settle)
    assert lines and any("40" in l for l in lines), lines


def test_config_error_carries_key_line_column_and_message(settle):
    settle["contact"]["friction"] = -0.5
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check(settle)
    e = info.value
    assert isinstance(e, ValueError)
    assert e.key == "contact.friction"
    assert e.file == "<dict>"
    # a dict has no lines: the key path says where (line and column 0)
    assert (e.line, e.column) == (0, 0)
    assert "-0.5" in e.message and "allowed" in e.message
    assert str(e).startswith("<dict>: key `contact.friction`: ") and "line" not in str(e)


def test_unknown_key_and_experiment_are_named(settle):
    settle["contact"]["frction"] = 0.3
    with pytest.raises(grainwave.ConfigError, match="friction") as info:
        grainwave.check(settle)
    assert info.value.key is not None and "frction" in info.value.key
    with pytest.raises(grainwave.ConfigError, match=r"did you mean `simulation`") as info:
        grainwave.check({"experiment": "simulatoin"})
    assert info.value.key == "experiment"


def test_syntax_error_and_missing_file_point_at_their_place(tmp_path):
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check('experiment = "simulation"\nseed = = 1\n')
    assert info.value.line == 2 and info.value.column > 0 and info.value.file == "<string>"
    missing = tmp_path / "nope.toml"
    with pytest.raises(grainwave.ConfigError, match="cannot read the config file") as info:
        grainwave.check(missing)
    assert info.value.file == str(missing) and info.value.line == 0


def test_run_gives_summary_tables_and_arrays(tmp_path, settle):
    r = grainwave.run(settle, out=tmp_path / "run", threads=1)
    assert r.out == tmp_path / "run"
    assert r.summary["experiment"] == "simulation" and r.summary["steps"] == 3000
    assert r.summary["grains"] == 40
    series = r.tables["series"]
    np.testing.assert_array_equal(series["step"], np.arange(0, 3001, 500, dtype=float))
    # the NumPy archive and the CSV hold the same series
    np.testing.assert_array_equal(r.arrays["series"]["time"], series["time"])
    grains = r.tables["grains"]
    assert grains["radius"].shape == (40,) and np.all(grains["radius"] > 0)
    assert "summary.json" in r.files and r.lines
    # the same result read back from the directory
    again = grainwave.load_result(r.out)
    assert again.summary == r.summary


def test_a_used_directory_is_refused_unless_overwrite(tmp_path, settle):
    out = tmp_path / "run"
    settle["stop"]["step_limit"] = 100
    grainwave.run(settle, out=out, threads=1)
    with pytest.raises(ValueError, match="holds the outputs of an earlier run"):
        grainwave.run(settle, out=out, threads=1)
    assert grainwave.run(settle, out=out, threads=1, overwrite=True).summary["steps"] == 100


def test_a_refused_config_leaves_the_directory_alone(tmp_path, settle):
    settle["grains"]["count"] = -3
    with pytest.raises(grainwave.ConfigError):
        grainwave.run(settle, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_thread_count_is_checked_and_changes_no_bit(tmp_path, settle):
    with pytest.raises(ValueError, match="threads = 0"):
        grainwave.run(settle, out=tmp_path / "x", threads=0)
    a = grainwave.run(settle, out=tmp_path / "one", threads=1)
    b = grainwave.run(settle, out=tmp_path / "two", threads=2)
    assert dir_files(a.out) == dir_files(b.out)


def test_python_run_is_the_command_line_run_bit_for_bit(tmp_path, settle, cli):
    config = tmp_path / "settle.toml"
    config.write_text(_config.dumps(settle))
    subprocess.run([cli, "--quiet", "--threads", "1", "run", str(config), "--out", str(tmp_path / "cli")], check=True)
    r = grainwave.run(config, out=tmp_path / "py", threads=1)
    cli_files, py_files = dir_files(tmp_path / "cli"), dir_files(r.out)
    assert sorted(cli_files) == sorted(py_files)
    assert "checkpoint.gwck" in py_files and "series.npz" in py_files
    for name in cli_files:
        assert cli_files[name] == py_files[name], name
    # a dict gives the same bits as the file written from it
    d = grainwave.run(settle, out=tmp_path / "dict", threads=1)
    assert dir_files(d.out) == py_files


def test_progress_callback_sees_stages_and_steps(tmp_path, settle):
    events = []
    grainwave.run(settle, out=tmp_path / "run", threads=1, progress=events.append)
    kinds = {e["kind"] for e in events}
    assert {"stage", "progress"} <= kinds, kinds
    steps = [e["step"] for e in events if e["kind"] == "progress"]
    assert steps == sorted(steps) and steps[-1] == 3000
    stage = next(e for e in events if e["kind"] == "stage")
    assert stage["name"] == "simulation" and stage["total_steps"] == 3000


def test_progress_true_works_without_a_terminal(tmp_path, settle, capsys):
    settle["stop"]["step_limit"] = 200
    assert grainwave.run(settle, out=tmp_path / "run", threads=1, progress=True).summary["steps"] == 200
    with pytest.raises(TypeError, match="progress: None, True or a callable expected"):
        grainwave.run(settle, out=tmp_path / "bad", progress=3)


def long_settle(settle):
    settle["stop"]["step_limit"] = 20000
    settle["output"]["series_every"] = 2000
    return settle


def test_ctrl_c_saves_the_state_and_resume_gives_the_same_bits(tmp_path, settle):
    settle = long_settle(settle)
    straight = grainwave.run(settle, out=tmp_path / "straight", threads=1)
    sent = []

    def press_ctrl_c(event):
        # the signal Ctrl-C sends, delivered to this process while the run goes on
        if event["kind"] == "progress" and 0 < event["step"] < 20000 and not sent:
            sent.append(event["step"])
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(grainwave.Interrupted) as info:
        grainwave.run(settle, out=tmp_path / "cut", threads=1, progress=press_ctrl_c)
    e = info.value
    assert isinstance(e, KeyboardInterrupt)
    assert Path(e.dir) == tmp_path / "cut" and Path(e.checkpoint).is_file()
    assert "resume" in str(e)
    assert not (tmp_path / "cut" / "summary.json").exists()
    resumed = grainwave.resume(tmp_path / "cut", threads=1)
    assert resumed.summary["steps"] == 20000
    assert dir_files(resumed.out) == dir_files(straight.out)


def test_an_exception_of_the_callback_stops_the_run_with_its_state_saved(tmp_path, settle):
    settle = long_settle(settle)

    def fail(event):
        if event["kind"] == "progress" and event["step"] > 0:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough") as info:
        grainwave.run(settle, out=tmp_path / "cut", threads=1, progress=fail)
    assert not isinstance(info.value, grainwave.RunError)
    assert (tmp_path / "cut" / "checkpoint.gwck").is_file()
    assert grainwave.resume(tmp_path / "cut", threads=1).summary["steps"] == 20000


def test_resume_refuses_what_cannot_be_resumed(tmp_path):
    with pytest.raises(ValueError, match="is not a directory"):
        grainwave.resume(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no `checkpoint.gwck` there"):
        grainwave.resume(tmp_path / "empty")
    with pytest.raises(ValueError, match="no summary.json"):
        grainwave.load_result(tmp_path / "empty")


def test_a_failed_run_raises_run_error(tmp_path, settle):
    # a time step of 0.5 under g = 100: the first step throws grains through the floor — a
    # numerical failure of the run (RunError), not bad input; the directory is marked failed
    settle["integration"] = {"dt": 0.5}
    settle["placement"] = {"method": "lattice"}
    settle["gravity"] = [0.0, -100.0]
    grainwave.check(settle)
    with pytest.raises(grainwave.RunError, match=r"numerical blow-up at step 0 .*left the domain through wall `floor`"):
        grainwave.run(settle, out=tmp_path / "run", threads=1)
    assert (tmp_path / "run" / "run.failed").is_file()
    with pytest.raises(ValueError, match=r"the run failed: .*retry=True"):
        grainwave.resume(tmp_path / "run")


def test_tables_are_numbers_where_every_value_is_one(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("group,x,failure,gap\na,1.5,,\nb,NaN,,2\n")
    t = grainwave.read_table(p)
    assert t["group"].tolist() == ["a", "b"]
    assert t["x"].dtype == np.float64 and t["x"][0] == 1.5 and np.isnan(t["x"][1])
    # a column with no value at all is text (e.g. `failure` when nothing failed)
    assert t["failure"].tolist() == ["", ""]
    assert np.isnan(t["gap"][0]) and t["gap"][1] == 2.0
