#!/usr/bin/env python3
"""What the tail time step of the E1 preparation changes: two runs of the same packings (same seeds,
gas and protocol), one with `preparation.tail_dt_factor = 1` (off) and one with the default 3,
compared per pressure: preparation steps, the largest shift of an ensemble mean in units of the
ensemble SD, and the per-packing change of C₃₃ paired by seed.

    python3 examples/papers/e1-tail-dt.py docs/data/e1-tables-tail1 docs/data/e1-tables

Each argument is a run directory (or a copy of its samples.csv). Standard library only.
"""
import csv
import math
import os
import sys

QUANTITIES = ["phi2", "phi3_star", "z_star", "Z2", "F2", "sigma_ratio", "C11", "C12", "C22", "C33", "c_l"]


def samples(d):
    with open(os.path.join(d, "samples.csv"), newline="") as f:
        out = {}
        for r in csv.DictReader(f):
            if r.get("failure"):
                continue
            out[(float(r["pressure"]), int(r["seed"]))] = r
        return out


def mean(xs):
    return sum(xs) / len(xs)


def sd(xs):
    m = mean(xs)
    return math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1))


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    off, on = samples(argv[0]), samples(argv[1])
    print("| p | packings | preparation steps, factor 1 → 3 | largest shift of an ensemble mean (in ensemble SDs) "
          "| per-packing \\|ΔC₃₃\\|/C₃₃, median (max) |")
    print("|---|---|---|---|---|")
    total = [0.0, 0.0]
    for p in sorted({k[0] for k in off}, reverse=True):
        seeds = sorted(s for (q, s) in off if q == p and (q, s) in on)
        if not seeds:
            continue
        a = [off[(p, s)] for s in seeds]
        b = [on[(p, s)] for s in seeds]
        sa = sum(float(r["preparation_steps"]) for r in a)
        sb = sum(float(r["preparation_steps"]) for r in b)
        total[0] += sa / len(seeds)
        total[1] += sb / len(seeds)
        worst, which = 0.0, ""
        for q in QUANTITIES:
            xa = [float(r[q]) for r in a]
            xb = [float(r[q]) for r in b]
            shift = abs(mean(xb) - mean(xa)) / sd(xa)
            if shift > worst:
                worst, which = shift, q
        d = sorted(abs(float(rb["C33"]) / float(ra["C33"]) - 1) for ra, rb in zip(a, b))
        med = d[len(d) // 2] if len(d) % 2 else 0.5 * (d[len(d) // 2 - 1] + d[len(d) // 2])
        print(f"| {p:g} | {len(seeds)} | {sa:.3g} → {sb:.3g} (**{sa / sb:.2f} ×**) | {worst:.3f} ({which}) | {med:.1e} ({d[-1]:.1e}) |")
    print(f"\nper packing of the four pressures: {total[0]:.3g} → {total[1]:.3g} steps ({total[0] / total[1]:.2f} × fewer)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
