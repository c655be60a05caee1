"""A pile settling under gravity, stepped from Python: build it from a dict (the keys of
examples/settle-pile.toml, fewer grains), watch the energy while stepping, stop at static
equilibrium, check that the floor carries the weight from the contact records, plot the force
network, compute the packing's vibration modes and the pulse the floor's kick sends to the right
wall (mode sum and direct integration), and save/continue a checkpoint.

    python3 examples/python/settle.py [OUT_DIR]

Writes OUT_DIR/force_network.png, OUT_DIR/energy.png and OUT_DIR/pulse.png (default OUT_DIR:
grainwave-out/python-settle).
"""

import sys
from pathlib import Path

import numpy as np

import grainwave

ROOT = Path(__file__).resolve().parents[2]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("grainwave-out/python-settle")
out.mkdir(parents=True, exist_ok=True)

config = grainwave.read_config(ROOT / "examples/settle-pile.toml")  # a dict, on any Python ≥ 3.9
config["grains"]["count"] = 120
config["domain"]["size"] = [12.0, 30.0]

sim = grainwave.Simulation(config)  # placed, not stepped
print(sim)

# step in blocks of 2000, recording the kinetic energy per grain
times, energies = [], []
while True:
    sim.step(2000)
    times.append(sim.time)
    energies.append(sim.kinetic_energy / len(sim))
    if energies[-1] < 1e-6 or sim.step_count >= 400_000:
        break
# then the config's own equilibrium criteria ([stop]: KE per grain 1e-12, max acceleration 1e-7)
outcome = sim.run_until()
print(f"run_until: {outcome}; step {sim.step_count}, t = {sim.time:.1f}")

# contact records: the walls carry the weight (static equilibrium, frictionless side walls)
c = sim.contacts()
f_i = c["tangential_force"] - c["normal_force"][:, None] * c["normal"]  # force on grain i
on_walls = c["wall"] >= 0
weight = sim.masses.sum() * abs(config["gravity"][1])
support = f_i[on_walls, 1].sum()  # the walls push the grains up
print(f"{c['i'].size} contacts, {on_walls.sum()} on walls; walls carry {support / weight:.9f} × the weight")

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import LineCollection

x = sim.positions
pairs = c["j"] >= 0
segments = np.stack([x[c["i"][pairs]], x[c["i"][pairs]] + c["branch"][pairs]], axis=1)
fn = c["normal_force"][pairs]
fig, ax = plt.subplots(figsize=(5.5, 5))
for xy, r in zip(x, sim.radii):
    ax.add_patch(plt.Circle(xy, r, fill=False, lw=0.3, color="0.6"))
ax.add_collection(LineCollection(segments, linewidths=4 * fn / fn.max(), colors="k"))
ax.set_aspect("equal")
ax.set_xlim(0, 12)
ax.set_ylim(0, x[:, 1].max() + 1)
ax.set_title("force network (line width ∝ F_n)")
fig.tight_layout()
fig.savefig(out / "force_network.png", dpi=120)

fig, ax = plt.subplots(figsize=(5, 3.4))
ax.semilogy(times, energies)
ax.set_xlabel("time √(d/g)")
ax.set_ylabel("kinetic energy per grain")
fig.tight_layout()
fig.savefig(out / "energy.png", dpi=120)

# linear analysis of the packing: modes of D v = ω² M v, and the pulse of a kick of the floor
# (wall 0) seen on the right wall (wall 2), by the mode sum and by direct integration
import grainwave.linear as gl

modes = gl.modes(sim)
w = np.sqrt(np.clip(modes["omega_squared"], 0, None))
print(f"{w.size} modes, ω from {w[w > 1e-6].min():.3g} to {w.max():.3g}")
t = np.linspace(0.0, 2.0, 401)
modal = gl.modal_pulse(sim, 0, 2, t)
direct = gl.direct_pulse(sim, 0, 2, t, steps_per_period=40.0)
print(f"pulse: max |modal − direct| = {np.abs(modal['signal'] - direct['signal']).max():.2e} of {np.abs(modal['signal']).max():.3e}")
fig, ax = plt.subplots(figsize=(5.5, 3.4))
ax.plot(t, modal["signal"], label="mode sum")
ax.plot(t, direct["signal"], "--", label="direct integration")
ax.set_xlabel("time √(d/g)")
ax.set_ylabel("force on the right wall")
ax.set_title("pulse from a kick of the floor")
ax.legend()
fig.tight_layout()
fig.savefig(out / "pulse.png", dpi=120)

# a checkpoint continues bit for bit
sim.save(out / "pile.gwck")
again = grainwave.Simulation.load(out / "pile.gwck")
sim.step(100)
again.step(100)
assert again.state_hash == sim.state_hash
print(f"plots: {out / 'force_network.png'}, {out / 'energy.png'}, {out / 'pulse.png'}; checkpoint {out / 'pile.gwck'}")
