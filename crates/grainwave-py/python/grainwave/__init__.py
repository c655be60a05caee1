"""grainwave: discrete-element simulations of granular materials, from Python.

Studies (any config the command line runs)::

    import grainwave
    grainwave.check("examples/e1-chain.toml")          # -> lines, or raises grainwave.ConfigError
    r = grainwave.run("examples/e1-chain.toml", out="out/chain", progress=True)
    r.summary["..."], r.tables["heights"]["peak_time"]  # dict, NumPy arrays
    grainwave.resume("out/chain")                       # after Ctrl-C (grainwave.Interrupted)

Simulations::

    sim = grainwave.Simulation({"experiment": "simulation", ...})   # or grainwave.load(path)
    sim.step(1000); x = sim.positions; c = sim.contacts()
    packing = grainwave.load("out/e1/samples/p1e-4_L8/s0001/packing.gwck")   # a study's state

A config is a path, a TOML string or a dict. See docs/python.md.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

from . import _config, _progress, linear
from ._native import VERSION, ConfigError, Interrupted, RunError, Simulation as _NativeSimulation
from ._result import Result, read_table
from ._tables import Columns

__version__ = VERSION
__all__ = [
    "check",
    "run",
    "resume",
    "load_result",
    "load",
    "read_config",
    "Simulation",
    "Columns",
    "Result",
    "ConfigError",
    "Interrupted",
    "RunError",
    "read_table",
    "linear",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]


def check(config: Any, allow_large: bool = False) -> List[str]:
    """Validates a config (path, TOML string or dict) without running it. Returns the lines
    ``grainwave check`` prints; raises :class:`ConfigError` (with ``key``, ``line``, ``column``,
    ``message``) when it is invalid, a ``FileNotFoundError`` (also a ``ConfigError``) when the
    file does not exist. ``allow_large``: lift the soft limits on sizes (grains, samples,
    points; sizes that need more memory than the machine has stay refused)."""
    from . import _native

    return _native.check(*_config.normalize(config), bool(allow_large))


def read_config(config: Any) -> Dict[str, Any]:
    """A config file (a path) or TOML text as a dict, to change a few keys and give it to
    :func:`run` or :class:`Simulation` (on any Python version: no ``tomllib`` needed). The keys
    are not validated here (:func:`check` does that); a syntax error raises
    :class:`ConfigError`, a file that does not exist ``FileNotFoundError``."""
    from . import _native

    if isinstance(config, dict):
        raise TypeError("config: a path or TOML text expected, a dict given (it is already a dict)")
    return _native.read_config(*_config.normalize(config))


def load(path: PathLike) -> "Simulation":
    """The engine state stored in a checkpoint, as a :class:`Simulation` (which
    :mod:`grainwave.linear` analyses and which can be stepped on): a file written by
    ``Simulation.save``, a ``simulation`` run's ``checkpoint.gwck`` or output directory, or a
    state a study stored — an E1 packing (``samples/<group>/s<seed>/packing.gwck``), an E2
    strain checkpoint stored in full (``checkpoints/ck-<k>.gwck``), an E3 reference state
    (``units/<case>/reference.gwck``). The same as ``Simulation.load``."""
    return Simulation.load(path)


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
    allow_large: bool = False,
) -> Result:
    """Runs a config (path, TOML string or dict) into the directory ``out`` (default
    ``grainwave-out/<config file name>``, or ``grainwave-out/<experiment>`` for a string or
    dict), with ``threads`` worker threads (default one per core; the results are the same
    bits for any count). ``progress``: None, True (a tqdm bar, or lines on stderr) or a callable
    receiving event dicts. A directory holding an earlier run is refused unless ``overwrite``
    (then its outputs are replaced). ``allow_large``: lift the soft limits on sizes (the command
    line's ``--allow-large``; sizes that need more memory than the machine has stay refused).

    The GIL is released during the run. Ctrl-C stops it after the current step with its state
    saved and raises :class:`Interrupted` (``resume(out)`` continues bit for bit)."""
    from . import _native

    target = Path(out) if out is not None else _default_out(config)
    callback, close = _progress.make(progress)
    try:
        report, lines, out_dir = _native.run(*_config.normalize(config), os.fspath(target), overwrite, threads, callback, bool(allow_large))
    finally:
        close()
    import json

    return Result(Path(out_dir), json.loads(report), lines)


def resume(dir: PathLike, threads: Optional[int] = None, progress: Any = None, retry: bool = False, allow_large: bool = False) -> Result:
    """Continues the interrupted run of output directory ``dir`` from its checkpoint (the same
    bits as an uninterrupted run). ``retry``: also a run that failed (``run.failed``).
    ``allow_large``: as for :func:`run` (give it again when the run was started with it)."""
    from . import _native

    callback, close = _progress.make(progress)
    try:
        report, lines, out_dir = _native.resume(os.fspath(dir), threads, callback, retry, bool(allow_large))
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
