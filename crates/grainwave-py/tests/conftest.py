"""Fixtures of the Python module's tests: small configs (seconds each) and the command-line
program for the bit-for-bit comparisons."""

import copy
import os
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]

# 40 disks falling in a box (2D): contacts form within the 3000 steps, ~0.1 s of computing.
SETTLE = {
    "experiment": "simulation",
    "seed": 7,
    "gravity": [0.0, -1.0],
    "grains": {
        "kind": "disk",
        "count": 40,
        "density": 1.0,
        "size": {"distribution": "uniform_diameter", "mean_diameter": 1.0, "spread": 0.2},
    },
    "domain": {"size": [8.0, 16.0]},
    "placement": {"method": "gas"},
    "contact": {"preset": "hooke_cundall_strack", "normal_stiffness": 1.0e4, "restitution": 0.5, "friction": 0.3},
    "walls": [
        {"name": "floor", "axis": "y", "side": "low"},
        {"name": "left", "axis": "x", "side": "low"},
        {"name": "right", "axis": "x", "side": "high"},
    ],
    "stop": {"step_limit": 3000},
    "output": {"series_every": 500},
}


@pytest.fixture(autouse=True, scope="session")
def ctrl_c_reaches_python():
    """The tests of Ctrl-C send SIGINT to this process. A runner started in the background by a
    non-interactive shell (`cmd &`, `nohup`) inherits SIGINT ignored, and Python then installs no
    handler, so no Ctrl-C could reach a run: give SIGINT Python's default handler for the session
    (as in any terminal), and put the inherited disposition back after it."""
    inherited = signal.getsignal(signal.SIGINT)
    if inherited == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, inherited)


@pytest.fixture
def settle():
    """A fresh copy of the settling config (tests may edit it)."""
    return copy.deepcopy(SETTLE)


@pytest.fixture(scope="session")
def cli():
    """The command-line program: $GRAINWAVE_BIN, or the release build of this checkout (built by
    `cargo test --workspace --release`, which .ci/run runs first)."""
    path = os.environ.get("GRAINWAVE_BIN") or str(ROOT / "target" / "release" / "grainwave")
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        if os.environ.get("CI"):
            pytest.fail(f"the command-line program is not at {path} (build it with cargo build --release)")
        pytest.skip(f"skipped: the command-line program is not at {path} (cargo build --release, or set GRAINWAVE_BIN)")
    return path


def dir_files(d: Path):
    """Every file of an output directory that a run writes deterministically, with its bytes:
    all but run.log (wall-clock times) and the lock file."""
    out = {}
    for p in sorted(Path(d).rglob("*")):
        if p.is_file() and p.name not in ("run.log", ".grainwave.lock"):
            out[str(p.relative_to(d))] = p.read_bytes()
    return out


def contact_force_sum(sim):
    """The force on each grain of a 2D simulation under gravity (0, −1) summed from its contact
    records (−F_n n̂ + F_t on i, the opposite on j) plus its weight, and the largest contact
    force (the scale of a tolerance)."""
    c = sim.contacts()
    f_i = c["tangential_force"] - c["normal_force"][:, None] * c["normal"]
    total = np.zeros((len(sim), 2))
    np.add.at(total, c["i"], f_i)
    pairs = c["j"] >= 0
    np.add.at(total, c["j"][pairs], -f_i[pairs])
    total[:, 1] -= sim.masses
    return total, np.abs(f_i).max()
