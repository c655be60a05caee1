"""From an E1 study to the linear analysis of one of its packings: run
examples/e1-pulse-2d.toml (8 packings of ≈ 50–100 disks, seconds), open one sample's prepared
packing (samples/<group>/s<seed>/packing.gwck) with grainwave.load, compute its vibration modes,
moduli and the pulse of a kick of the bottom wall seen on the top wall, and check them against
the numbers the study wrote for that sample (its signal column and its C11).

    python3 examples/python/e1_packing.py [OUT_DIR]

Writes OUT_DIR/packing_pulse.png (default OUT_DIR: grainwave-out/python-e1-packing); the
study's outputs go to OUT_DIR/study.
"""

import sys
from pathlib import Path

import numpy as np

import grainwave
import grainwave.linear as gl

ROOT = Path(__file__).resolve().parents[2]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("grainwave-out/python-e1-packing")
out.mkdir(parents=True, exist_ok=True)

study = grainwave.run(ROOT / "examples/e1-pulse-2d.toml", out=out / "study", overwrite=True, progress=True)

group, seed = "p1e-4_L8", 1  # pressure 1e-4, target height 8; the first sample
sim = grainwave.load(study.out / "samples" / group / f"s{seed:04d}" / "packing.gwck")
print(sim)

# the study's own numbers for this sample
samples = study.tables["samples"]
row = np.flatnonzero((samples["group"] == group) & (samples["seed"] == seed))[0]
signals = study.tables[f"signals/{group}"]
t, theirs = signals["time"], signals[f"s{seed:04d}"]

# the same analysis from Python: E1's defaults (no prestress term, rattlers kept), the kick of
# the bottom wall (wall 0, impulse strength 1) seen on the top wall (wall 1)
modes = gl.modes(sim)
w = np.sqrt(np.clip(modes["omega_squared"], 0, None))
print(f"{w.size} modes; ω from {w[w > 1e-9].min():.4g} to {w.max():.4g}; {np.sum(w <= 1e-9)} (near) zero modes")
ours = gl.modal_pulse(sim, 0, 1, t)["signal"]
difference = np.abs(ours - theirs).max() / np.abs(theirs).max()
print(f"pulse: max |ours − study| = {difference:.1e} of the peak")
c11 = gl.moduli(sim)["voigt"][0][0]
print(f"C11 = {c11:.10g} (study: {samples['C11'][row]:.10g})")
assert difference < 1e-10 and abs(c11 / samples["C11"][row] - 1) < 1e-9

try:
    import matplotlib
except ImportError:
    print("matplotlib not installed: no plot (pip install matplotlib)")
    sys.exit(0)
matplotlib.use("Agg")
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(5.5, 3.4))
ax.plot(t, theirs, lw=3, alpha=0.4, label="study (signals csv)")
ax.plot(t, ours, "k", lw=1, label="grainwave.linear.modal_pulse")
ax.set_xlabel("time")
ax.set_ylabel("force on the top wall")
ax.set_title(f"{group}, sample {seed}")
ax.legend()
fig.tight_layout()
fig.savefig(out / "packing_pulse.png", dpi=120)
print(f"plot: {out / 'packing_pulse.png'}")
