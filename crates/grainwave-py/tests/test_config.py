"""Configs given as dicts and strings: the TOML they become, and what is refused."""

import math
import subprocess
import sys
from pathlib import Path

try:
    import tomllib  # Python ≥ 3.11: the independent reader the tests compare with
except ImportError:  # older Pythons: those comparisons are skipped
    tomllib = None

import numpy as np
import pytest

import grainwave
from grainwave import _config


def test_dict_becomes_the_same_toml_data(settle):
    if tomllib is None:
        pytest.skip("skipped: tomllib (Python ≥ 3.11) not available")
    settle["note key"] = "quotes \" and\nnewlines"  # a key that needs quoting, an escaped string
    settle["grains"]["size"]["spread"] = np.float64(0.25)  # NumPy scalars are numbers
    settle["domain"]["size"] = np.array([8.0, 16.0])
    settle["inf"] = math.inf
    text = _config.dumps(settle)
    back = tomllib.loads(text)
    assert back["walls"] == settle["walls"]
    assert back["note key"] == settle["note key"]
    assert back["grains"]["size"]["spread"] == 0.25
    assert back["domain"]["size"] == [8.0, 16.0]
    assert back["inf"] == math.inf
    # tables and arrays of tables get lines of their own (errors point at them)
    assert "\n[grains.size]\n" in text and text.count("[[walls]]") == 3


def test_none_and_unknown_types_are_refused_by_key(settle):
    settle["contact"]["friction"] = None
    with pytest.raises(TypeError, match=r"`contact.friction`: None has no TOML form"):
        _config.dumps(settle)
    with pytest.raises(TypeError, match=r"config: a path, a TOML string or a dict expected, int given"):
        grainwave.check(42)


def test_path_string_and_dict_are_told_apart(tmp_path, settle):
    p = tmp_path / "c.toml"
    p.write_text(_config.dumps(settle))
    assert _config.normalize(p) == (str(p), str(p), None)
    assert _config.normalize(str(p)) == (str(p), str(p), None)
    assert _config.normalize("a = 1\n")[0] is None
    assert _config.normalize(settle)[1] == "<dict>"
    # the three forms describe the same run
    assert grainwave.check(p) == grainwave.check(str(p)) == grainwave.check(p.read_text()) == grainwave.check(settle)


def test_read_config_is_the_toml_data_without_tomllib():
    # the standard library reads TOML only from Python 3.11; read_config works on every Python
    # the module supports
    if tomllib is None:
        pytest.skip("skipped: tomllib (Python ≥ 3.11) not available")
    for name in ("settle-pile.toml", "e1-pulse-2d.toml", "e2-biaxial.toml"):
        path = Path(__file__).resolve().parents[3] / "examples" / name
        with open(path, "rb") as f:
            assert grainwave.read_config(path) == tomllib.load(f), name
    assert grainwave.read_config("a = inf\nb = [1, 2.5]\n[t]\nc = 'x'\n") == {"a": math.inf, "b": [1, 2.5], "t": {"c": "x"}}
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.read_config("a = = 1\n")
    assert info.value.line == 1 and info.value.file == "<string>"


def test_settle_example_runs_without_tomllib(tmp_path):
    # the example on a Python without tomllib (< 3.11): the import of tomllib made to fail
    pytest.importorskip("matplotlib", reason="skipped: matplotlib not available (pip install matplotlib)")
    root = Path(__file__).resolve().parents[3]
    script = root / "examples" / "python" / "settle.py"
    code = "import sys, runpy; sys.modules['tomllib'] = None; sys.argv = [sys.argv[1], sys.argv[2]]; runpy.run_path(sys.argv[0], run_name='__main__')"
    done = subprocess.run([sys.executable, "-c", code, str(script), str(tmp_path / "out")], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert (tmp_path / "out" / "pulse.png").is_file()
