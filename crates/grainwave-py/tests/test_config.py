"""Configs given as dicts and strings: the TOML they become, and what is refused."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import grainwave
from grainwave import _config


def test_dict_becomes_the_same_toml_data(settle):
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
