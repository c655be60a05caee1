"""The incremental pulse of a frictional packing for both signs of the pulse: a pile of 150 disks
(friction 0.3) settles under gravity, then the right wall squeezes it slowly (0.005 d/√(d/g)), so
that about one contact in five sits at the Coulomb limit (a pile left at rest relaxes them all);
that quasi-static state's floor gets a δ kick upward (+1, compression) and downward (−1,
rarefaction) through the piecewise-linear contact network (contacts at the limit slip while
pushed on, stick once unloaded), and the strip fit of the arrival times gives the pulse speed of
each sign. With every contact sticking the two signs are mirror images (a check).

    python3 examples/python/incremental.py

Runs in a few seconds; prints the contact counts and c(+), c(−).
"""

import numpy as np

import grainwave
import grainwave.linear as gl

config = {
    "experiment": "simulation",
    "seed": 42,
    "gravity": [0.0, -1.0],
    "grains": {"kind": "disk", "count": 150, "density": 1.0, "size": {"distribution": "uniform_diameter", "mean_diameter": 1.0, "spread": 0.2}},
    "domain": {"size": [10.0, 40.0]},
    "placement": {"method": "gas", "region_min": [0.0, 5.0]},
    "contact": {"preset": "hooke_cundall_strack", "normal_stiffness": 1.0e4, "restitution": 0.5, "friction": 0.3},
    "walls": [
        {"name": "floor", "axis": "y", "side": "low"},
        {"name": "left", "axis": "x", "side": "low"},
        # fixed while the pile settles (t < 19), then moving in at 0.005
        {"name": "right", "axis": "x", "side": "high", "motion": "velocity", "speed": {"type": "ramp", "from": 0.0, "to": 0.005, "start": 19.0, "end": 20.0}},
    ],
    "stop": {"step_limit": 1},
}

sim = grainwave.Simulation(config)
sim.step(47_500)  # t ≈ 30: squeezed by about 0.05 d
print(f"t = {sim.time:.1f}: kinetic energy per grain {sim.kinetic_energy / len(sim):.1e} (quasi-static)")

# kick of the floor (wall 0), sampled every 0.002 for 0.4 (the pulse crosses the pile in ~0.2)
kw = dict(duration=0.4, sample_interval=0.002, strips=16)
plus = gl.incremental_pulse(sim, 0, amplitude=1.0, **kw)
minus = gl.incremental_pulse(sim, 0, amplitude=-1.0, **kw)
counts = plus["counts"]
print(f"{counts['contacts']} contacts, {counts['at_limit']} at the Coulomb limit; slipped: {plus['counts']['slipped']} (+), {minus['counts']['slipped']} (−)")
print(f"{plus['steps']} steps of {plus['max_step']:.3g} each, {plus['wall_seconds']:.2f} s per sign")


def speed(r):
    return f"{r['fit']['speed']:.2f} d/√(d/g) ({r['fit']['strips_used']} strips)" if r["fit"] else "no front found"


print(f"c(+) = {speed(plus)}")
print(f"c(−) = {speed(minus)}")
scale = np.abs(plus["velocity"]).max()
print(f"max |v(−) + v(+)| / max |v(+)| = {np.abs(minus['velocity'] + plus['velocity']).max() / scale:.3f} (0 for a linear network)")

stick = [gl.incremental_pulse(sim, 0, amplitude=a, branches="stick", **kw) for a in (1.0, -1.0)]
assert np.array_equal(stick[1]["velocity"], -stick[0]["velocity"])
print(f"all contacts sticking: c = {speed(stick[0])} for both signs")
