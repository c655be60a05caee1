"""Messages that speak Python: the command line's flags and commands named as the keyword
arguments and calls that do the same, missing paths as FileNotFoundError, config errors with
the command line's excerpt, dict configs named by their key path."""

import errno
import os
import re
import signal
from pathlib import Path

import pytest

import grainwave
from grainwave import _config, _native

ROOT = Path(__file__).resolve().parents[3]

# a tiny E1 study: one packing of ≈ 25 grains (a fraction of a second)
E1 = {
    "experiment": "e1",
    "seed": 1,
    "samples": 1,
    "packing": {"kind": "sphere2d", "width": 6.0, "heights": [4.0], "pressures": [1e-4], "friction": 0.5, "poisson": 0.0},
    "preparation": {"damping": 0.2, "max_acceleration": 1e-10},
    "pulse": {"initial_condition": "impulse", "method": "modal"},
}


@pytest.mark.parametrize(
    "cli, python",
    [
        ("continue with `grainwave resume out/a b`", 'continue with `grainwave.resume("out/a b")`'),
        ("replace it with `--overwrite`, or give another `--out`", "replace it with `overwrite=True`, or give another `out`"),
        ("`--allow-large` lifts this limit", "`allow_large=True` lifts this limit"),
        ("start it again with `grainwave run CONFIG --out d --overwrite`", 'start it again with `grainwave.run(config, out="d", overwrite=True)`'),
        ("(was the run started with `grainwave run … --out d`?)", '(was the run started with `grainwave.run(config, out="d")`?)'),
        ("(`grainwave resume DIR` continues the run)", "(`grainwave.resume(dir)` continues the run)"),
        ("key `contact.friction` in `a.toml`", "key `contact.friction` in `a.toml`"),
    ],
)
def test_command_line_words_become_python_words(cli, python):
    assert _native._python_words(cli) == python


def test_no_message_of_the_library_is_left_in_command_line_words():
    # every code span of the library's messages that names a command or a flag (format strings
    # of the study crates; the command line's own crate excluded) comes out without `--` or a
    # `grainwave <command>`: a new message naming a new flag fails here until it is translated
    sources = [p for p in (ROOT / "crates").glob("*/src/**/*.rs") if "grainwave-cli" not in p.parts and "grainwave-py" not in p.parts]
    if not sources:
        pytest.skip("skipped: the crates' sources are not next to the tests")
    spans = set()
    for p in sources:
        for line in p.read_text(encoding="utf-8").splitlines():
            if line.lstrip().startswith("//"):
                continue
            for literal in re.findall(r'"((?:[^"\\]|\\.)*)"', line):
                for span in literal.split("`")[1::2]:
                    if span.startswith("--") or re.match(r"grainwave (run|resume|check)\b", span):
                        spans.add(span)
    assert spans, "no command-line words found: the scan is broken"
    for span in sorted(spans):
        out = _native._python_words(f"`{span}`")
        assert "--" not in out and not re.search(r"grainwave (run|resume|check)\b", out), (span, out)


def test_a_used_directory_names_overwrite_true_and_grainwave_resume(tmp_path, settle):
    settle["stop"]["step_limit"] = 100
    out = tmp_path / "run"
    grainwave.run(settle, out=out, threads=1)
    with pytest.raises(ValueError) as info:
        grainwave.run(settle, out=out, threads=1)
    text = str(info.value)
    assert "overwrite=True" in text and f'grainwave.resume("{out}")' in text, text
    assert "--" not in text and "grainwave resume" not in text, text


def test_an_interrupted_run_names_grainwave_resume(tmp_path, settle):
    settle["stop"]["step_limit"] = 20000
    sent = []

    def press_ctrl_c(event):
        if event["kind"] == "progress" and 0 < event["step"] < 20000 and not sent:
            sent.append(1)
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(grainwave.Interrupted) as info:
        grainwave.run(settle, out=tmp_path / "cut", threads=1, progress=press_ctrl_c)
    assert f'continue with `grainwave.resume("{tmp_path / "cut"}")`' in str(info.value), str(info.value)


def test_allow_large_lifts_the_soft_limits_for_the_call_only():
    big = dict(E1, samples=200_000, pulse=dict(E1["pulse"], time_samples=16))
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check(big)
    assert info.value.key == "samples"
    assert "`allow_large=True` lifts this limit" in info.value.message and "--allow-large" not in str(info.value)
    assert grainwave.check(big, allow_large=True)
    # the limit is back after the call
    with pytest.raises(grainwave.ConfigError, match="allow_large=True"):
        grainwave.check(big)
    with pytest.raises(grainwave.ConfigError, match="allow_large=True"):
        grainwave.run(big, out="never-written")
    assert not Path("never-written").exists()


def test_allow_large_is_an_argument_of_simulation(settle):
    # a simulation above the soft limit needs more memory than a test may take: the keyword is
    # accepted, and a size beyond the hard limit stays refused with it
    assert len(grainwave.Simulation(settle, allow_large=True)) == 40
    settle["grains"]["count"] = 5_000_000_000
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.Simulation(settle, allow_large=True)
    assert info.value.key == "grains.count"


def test_a_missing_config_file_is_a_file_not_found_error_and_a_config_error(tmp_path):
    missing = tmp_path / "nope.toml"
    for call in (grainwave.check, grainwave.Simulation, grainwave.read_config, lambda c: grainwave.run(c, out=tmp_path / "o")):
        with pytest.raises(FileNotFoundError) as info:
            call(missing)
        e = info.value
        assert isinstance(e, grainwave.ConfigError) and isinstance(e, ValueError)
        assert e.errno == errno.ENOENT and e.filename == str(missing)
        assert e.file == str(missing) and e.line == 0 and e.key is None
        assert str(e).startswith(f"{missing}: cannot read the config file"), str(e)
    assert not (tmp_path / "o").exists()


def test_a_missing_checkpoint_or_directory_is_a_file_not_found_error(tmp_path):
    for call in (grainwave.Simulation.load, grainwave.load, grainwave.resume, grainwave.load_result):
        with pytest.raises(FileNotFoundError) as info:
            call(tmp_path / "absent")
        assert isinstance(info.value, ValueError)  # what it was before
        assert info.value.filename == str(tmp_path / "absent")
        assert str(tmp_path / "absent") in str(info.value) and "Errno" not in str(info.value)


def test_config_error_of_a_file_carries_the_excerpt_and_caret(tmp_path, settle):
    settle["contact"]["friction"] = -0.5
    p = tmp_path / "c.toml"
    p.write_text(_config.dumps(settle))
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check(p)
    e = info.value
    lines = p.read_text().splitlines()
    row = next(k for k, l in enumerate(lines) if l.startswith("friction = -0.5")) + 1
    assert (e.line, e.column) == (row, len("friction = ") + 1)
    assert str(e).startswith(f"{p}:{row}:{e.column}: key `contact.friction`")
    # the command line's excerpt: the line with its number, and a mark under the value
    assert e.snippet is not None and e.__notes__ == [e.snippet]
    shown = e.snippet.splitlines()
    at = next(k for k, l in enumerate(shown) if "friction = -0.5" in l)
    assert shown[at].split("│")[0].strip() == str(row), shown
    mark = shown[at + 1]
    value_column = shown[at].index("-0.5")
    assert set(mark[value_column : value_column + 4]) <= set("─┬"), (shown[at], mark)
    assert set(mark[:value_column].replace("·", "").strip()) == set(), (shown[at], mark)
    # TOML text too (named <string>)
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check(p.read_text())
    assert info.value.file == "<string>" and "friction = -0.5" in info.value.snippet


def test_config_error_of_a_dict_names_the_key_path(settle):
    settle["walls"][1]["name"] = "floor"
    with pytest.raises(grainwave.ConfigError) as info:
        grainwave.check(settle)
    e = info.value
    assert e.key == "walls[1].name" and e.file == "<dict>"
    # no position in a text the user never saw: the key path, and the dict expression
    assert (e.line, e.column) == (0, 0)
    assert str(e).startswith("<dict>: key `walls[1].name`: "), str(e)
    assert e.snippet == 'in the dict: config["walls"][1]["name"]' and e.__notes__ == [e.snippet]
