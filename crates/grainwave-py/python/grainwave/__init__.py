"""grainwave: discrete-element simulations of granular materials, from Python.

Studies (any config the command line runs)::

    import grainwave
    grainwave.check("examples/e1-chain.toml")          # -> lines, or raises grainwave.ConfigError
    r = grainwave.run("examples/e1-chain.toml", out="out/chain", progress=True)
    r.summary["..."], r.tables["heights"]["peak_time"]  # dict, NumPy arrays
    grainwave.resume("out/chain")                       # after Ctrl-C (grainwave.Interrupted)

Simulations::

    sim = grainwave.Simulation({"experiment": "simulation", ...})   # or Simulation.load(path)
    sim.step(1000); x = sim.positions; c = sim.contacts()

A config is a path, a TOML string or a dict. See docs/python.md.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, List, Optional, Union

from . import _config, _progress, linear
from ._native import VERSION, ConfigError, Interrupted, RunError, Simulation as _NativeSimulation
from ._result import Result, read_table

__version__ = VERSION
__all__ = [
    "check",
    "run",
    "resume",
    "load_result",
    "Simulation",
    "Result",
    "ConfigError",
    "Interrupted",
    "RunError",
    "read_table",
    "linear",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]


def check(config: Any) -> List[str]:
    """Validates a config (path, TOML string or dict) without running it. Returns the lines
    ``grainwave check`` prints; raises :class:`ConfigError` (with ``key``, ``line``, ``column``,
    ``message``) when it is invalid."""
    from . import _native

    return _native.check(*_config.normalize(config))


def _default_out(config: Any) -> Path:
    if isinstance(config, (str, os.PathLike)) and not (isinstance(config, str) and ("\n" in config or "=" in config)):
        return Path("grainwave-out") / Path(os.fspath(config)).stem
    return Path("grainwave-out") / (_config.experiment_of(config) or "run")


def run(
    config: Any,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Any = None,
    overwrite: bool = False,
) -> Result:
    """Runs a config (path, TOML string or dict) into the directory ``out`` (default
    ``grainwave-out/<config file name>``, or ``grainwave-out/<experiment>`` for a string or
    dict), with ``threads`` worker threads (default one per core; the results are the same
    bits for any count). ``progress``: None, True (a tqdm bar, or lines on stderr) or a callable
    receiving event dicts. A directory holding an earlier run is refused unless ``overwrite``.

    The GIL is released during the run. Ctrl-C stops it after the current step with its state
    saved and raises :class:`Interrupted` (``resume(out)`` continues bit for bit)."""
    from . import _native

    target = Path(out) if out is not None else _default_out(config)
    callback, close = _progress.make(progress)
    try:
        report, lines, out_dir = _native.run(*_config.normalize(config), os.fspath(target), overwrite, threads, callback)
    finally:
        close()
    import json

    return Result(Path(out_dir), json.loads(report), lines)


def resume(dir: PathLike, threads: Optional[int] = None, progress: Any = None, retry: bool = False) -> Result:
    """Continues the interrupted run of output directory ``dir`` from its checkpoint (the same
    bits as an uninterrupted run). ``retry``: also a run that failed (``run.failed``)."""
    from . import _native

    callback, close = _progress.make(progress)
    try:
        report, lines, out_dir = _native.resume(os.fspath(dir), threads, callback, retry)
    finally:
        close()
    import json

    return Result(Path(out_dir), json.loads(report), lines)


def load_result(dir: PathLike) -> Result:
    """The result of a finished run, read from its output directory (e.g. one the command line
    wrote)."""
    return Result.from_dir(dir)


Simulation = _NativeSimulation
Simulation.__module__ = "grainwave"
