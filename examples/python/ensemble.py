"""An E1 ensemble from Python: run examples/e1-pulse-2d.toml (2 samples × 2 heights × 2
pressures, tens of seconds) with a progress bar, then plot its per-sample table — the first-peak
time of the pulse against the source–detector distance, one colour per pressure.

    python3 examples/python/ensemble.py [OUT_DIR]

Writes OUT_DIR/peak_times.png (default OUT_DIR: grainwave-out/python-ensemble). Ctrl-C stops
the run with its state saved; running the script again resumes it.
"""

import sys
from pathlib import Path

import numpy as np

import grainwave

ROOT = Path(__file__).resolve().parents[2]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("grainwave-out/python-ensemble")

if (out / "checkpoint.gwck").is_file() and not (out / "summary.json").is_file():
    result = grainwave.resume(out, progress=True)  # an interrupted run: continue it
else:
    result = grainwave.run(ROOT / "examples/e1-pulse-2d.toml", out=out, progress=True, overwrite=True)

samples = result.tables["samples"]  # one row per sample: str (group, failure), int (seed, grains), float others
print(f"{len(samples['seed'])} samples; columns: {', '.join(samples)}")
ok = samples["failure"] == ""
for p in np.unique(samples["pressure"]):
    rows = ok & (samples["pressure"] == p)
    print(f"p = {p:g}: heights {samples['height'][rows].round(2)}, peak times {samples['peak_time'][rows].round(3)}")

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(5, 3.6))
for p in np.unique(samples["pressure"]):
    rows = ok & (samples["pressure"] == p)
    ax.plot(samples["height"][rows], samples["peak_time"][rows], "o", label=f"p = {p:g}")
ax.set_xlabel("source–detector distance H (d̄)")
ax.set_ylabel("first-peak time (d̄ √(ρ/E*))")
ax.set_title("E1 ensemble: first-peak time per sample")
ax.legend()
fig.tight_layout()
fig.savefig(out / "peak_times.png", dpi=120)
print(f"plot: {out / 'peak_times.png'}")
