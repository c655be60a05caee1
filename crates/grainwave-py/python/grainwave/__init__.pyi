# Type stubs of the grainwave Python module (docs/python.md).
import os
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import linear as linear  # typed in linear.py

__version__: str
VERSION: str

PathLike = Union[str, os.PathLike[str]]
Config = Union[PathLike, str, Mapping[str, Any]]
"""A config: a file path, TOML text, or a dict (nested dicts are tables)."""
Progress = Union[None, bool, Callable[[Dict[str, Any]], None]]
"""None, True (a tqdm bar when installed, else lines on stderr) or a callable receiving event
dicts: {"kind": "stage", "name", "total_steps"}, {"kind": "progress", "step", "time",
"kinetic_energy_per_grain", "max_acceleration", "mean_acceleration", "contacts", "sliding",
"fraction"}, {"kind": "units", "done", "total"}, {"kind": "message", "text"}."""

class ConfigError(ValueError):
    """An invalid config."""
    file: str
    line: int
    """1-based line (0 when unknown)."""
    column: int
    """1-based column (0 when unknown)."""
    key: Optional[str]
    """Key path, e.g. "contact.friction"."""
    message: str
    """What is wrong and what is allowed."""
    snippet: Optional[str]
    """For a file or TOML text: the command line's excerpt (the lines around the value, a mark
    under it); for a dict: the expression that reaches the key (``config["contact"]["friction"]``).
    Also the exception's note (``__notes__``); None when there is no place to show."""

class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C after saving its state; ``resume(dir)`` continues it."""
    dir: Path
    checkpoint: Path

class RunError(RuntimeError):
    """A run that failed (numerical blow-up, every unit failed, outputs not writable)."""

class Columns(Dict[str, np.ndarray]):
    """A dict of columns (one entry per row): a table of a run, the contact records."""
    def records(self) -> np.ndarray:
        """The rows as a NumPy structured array (vector columns split into ``name_x``, …)."""
    def to_pandas(self) -> Any:
        """The rows as a ``pandas.DataFrame`` (needs pandas)."""

class Result:
    out: Path
    summary: Dict[str, Any]
    lines: List[str]
    @property
    def tables(self) -> Dict[str, Columns]: ...
    @property
    def arrays(self) -> Dict[str, Dict[str, np.ndarray]]: ...
    @property
    def files(self) -> List[str]: ...
    @classmethod
    def from_dir(cls, out: PathLike) -> Result: ...

def read_table(path: PathLike) -> Columns: ...
def read_config(config: Union[PathLike, str]) -> Dict[str, Any]: ...
def check(config: Config, allow_large: bool = False) -> List[str]: ...
def run(
    config: Config,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Progress = None,
    overwrite: bool = False,
    allow_large: bool = False,
) -> Result: ...
def resume(dir: PathLike, threads: Optional[int] = None, progress: Progress = None, retry: bool = False, allow_large: bool = False) -> Result: ...
def load_result(dir: PathLike) -> Result: ...
def load(path: PathLike) -> Simulation:
    """A checkpoint's engine state: Simulation.save's file, a simulation run's checkpoint or
    directory, an E1 packing.gwck, an E2 strain checkpoint stored in full, an E3 reference state."""

class Simulation:
    """One discrete-element simulation (2D or 3D). Per-grain arrays are read-only copies in the
    order of the grains' stable ids (``ids``)."""
    def __init__(self, config: Config, *, allow_large: bool = False) -> None: ...
    @staticmethod
    def load(path: PathLike) -> Simulation: ...
    def save(self, path: PathLike) -> None: ...
    def copy(self) -> Simulation: ...
    def __copy__(self) -> Simulation: ...
    def __deepcopy__(self, memo: Any) -> Simulation: ...
    def step(self, n: int = 1, *, progress: Progress = None) -> None: ...
    def run_until(
        self,
        *,
        step_limit: Optional[int] = None,
        time_limit: Optional[float] = None,
        max_acceleration: Optional[float] = None,
        mean_acceleration: Optional[float] = None,
        kinetic_energy_per_grain: Optional[float] = None,
        network_unchanged_steps: Optional[int] = None,
        no_sliding: bool = False,
        check_every: int = 0,
        not_before_time: Optional[float] = None,
        threads: Optional[int] = None,
        progress: Progress = None,
    ) -> Dict[str, Any]:
        """``step_limit``/``time_limit``: the step count and time at which the run stops,
        counted from the simulation's start (step 0), not from this call."""
    def __len__(self) -> int: ...
    @property
    def dimension(self) -> int: ...
    @property
    def step_count(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def grain_kind(self) -> str: ...
    @property
    def state_hash(self) -> int: ...
    @property
    def kinetic_energy(self) -> float: ...
    @property
    def elastic_energy(self) -> float: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def ids(self) -> npt.NDArray[np.int64]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def angular_velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def forces(self) -> npt.NDArray[np.float64]:
        """Forces of the last force evaluation (velocity Verlet: damping at the half-step
        velocities, so under damping not quite the sum of ``contacts()``)."""
    @property
    def torques(self) -> npt.NDArray[np.float64]: ...
    @property
    def radii(self) -> npt.NDArray[np.float64]: ...
    @property
    def masses(self) -> npt.NDArray[np.float64]: ...
    @property
    def inertias(self) -> npt.NDArray[np.float64]: ...
    def set_positions(self, positions: npt.ArrayLike) -> None: ...
    def set_velocities(self, velocities: npt.ArrayLike) -> None: ...
    def set_angular_velocities(self, angular_velocities: npt.ArrayLike) -> None: ...
    def set_external_forces(self, forces: npt.ArrayLike, torques: Optional[npt.ArrayLike] = None) -> None: ...
    def contacts(self) -> Columns: ...
    def write_snapshot(self, dir: PathLike) -> Tuple[str, str]: ...

