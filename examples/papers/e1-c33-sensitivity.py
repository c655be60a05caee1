#!/usr/bin/env python3
"""E1 C₃₃ sensitivity study (docs/validation.md, E1): each preparation variant against the baseline.

Usage:
    python3 examples/papers/e1-c33-sensitivity.py [--pressure 1e-4] BASELINE_DIR VARIANT_DIR...

BASELINE_DIR is a run of the documented defaults (examples/papers/e1-tables.toml or
e1-c33-p1e-4-baseline.toml); each VARIANT_DIR a run of one examples/papers/e1-c33-<p>-<variant>.toml
(its name is the directory name after the last "c33-<p>-", or give NAME=DIR). The script reads each
run's samples.csv; for a run that was interrupted (Ctrl-C / SIGTERM, resumable), write that file
from the finished samples first with `grainwave plot DIR`.

For every variant and modulus (C₁₁, C₁₂, C₂₂, C₃₃) it prints the mean ± standard deviation over the
samples, C₃₃ over the published value, Φ₂, z*, the preparation steps, and the difference to the
baseline **paired by seed** (a sample's seed fixes its grain sizes and gas positions, so the pair
differs only by the varied detail): mean relative difference ± its standard error over the pairs.
A difference is marked `*` when it exceeds two standard errors. Only samples without a failure and
at the chosen pressure are used; the n column says how many failed (e.g. stopped by the overlap
guard `max_overlap_fraction`), since the survivors of a variant with failures may be a biased set.
"""
import csv
import math
import os
import re
import sys

# Published Table II (VALIDATION.md, E1), reference only: nothing here is fitted to it.
PUBLISHED = {
    1e-7: {"C11": 9.9e-4, "C12": 8.1e-4, "C22": 13.9e-4, "C33": 1.2e-4, "phi2": 0.818, "z_star": 3.18},
    1e-6: {"C11": 2.3e-3, "C12": 1.7e-3, "C22": 3.2e-3, "C33": 0.35e-3, "phi2": 0.814, "z_star": 3.23},
    1e-5: {"C11": 5.4e-3, "C12": 3.5e-3, "C22": 7.4e-3, "C33": 1.1e-3, "phi2": 0.809, "z_star": 3.31},
    1e-4: {"C11": 1.35e-2, "C12": 6.8e-3, "C22": 1.88e-2, "C33": 4.0e-3, "phi2": 0.815, "z_star": 3.48},
}
MODULI = ["C11", "C12", "C22", "C33"]
KEYS = MODULI + ["phi2", "z_star", "preparation_steps"]


def load(d, p):
    fn = os.path.join(d, "samples.csv")
    if not os.path.exists(fn):
        sys.exit(f"{d}: no samples.csv — for an interrupted run, write it with `grainwave plot {d}`")
    out, failed = {}, 0
    for r in csv.DictReader(open(fn)):
        if not math.isclose(float(r["pressure"]), p, rel_tol=1e-9):
            continue
        if r["failure"]:
            failed += 1
            continue
        out[int(r["seed"])] = {k: float(r[k]) for k in KEYS}
    return out, failed


def mean_std(v):
    m = sum(v) / len(v)
    s = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else float("nan")
    return m, s


def fmt(m, s, k):
    if k.startswith("C"):
        return f"{m:.3g} ± {s:.2g}"
    if k == "preparation_steps":
        return f"{m / 1e3:.0f} k ± {s / 1e3:.0f} k"
    return f"{m:.3f} ± {s:.3f}"


def main(argv):
    p = 1e-4
    if len(argv) >= 2 and argv[0] == "--pressure":
        p = float(argv[1])
        argv = argv[2:]
    if len(argv) < 1:
        sys.exit(__doc__)
    pub = PUBLISHED.get(min(PUBLISHED, key=lambda q: abs(math.log(q / p))))
    base, base_failed = load(argv[0], p)
    if not base:
        sys.exit(f"{argv[0]}: no sample at p = {p:g}")
    variants = [("baseline", base, base_failed)]
    for a in argv[1:]:
        if "=" in a:
            name, d = a.split("=", 1)
        else:
            d = a.rstrip("/")
            m = re.search(r"c33-p\d+e-\d+-(.+)$", os.path.basename(d))
            name = m.group(1) if m else os.path.basename(d)
        variants.append((name, *load(d, p)))

    print(f"p = {p:g}; published: " + ", ".join(f"{k} = {pub[k]:g}" for k in MODULI))
    print()
    print("| variant | n | C₁₁ | C₁₂ | C₂₂ | C₃₃ | C₃₃/published | Φ₂ | z* | preparation steps |"
          " ΔC₁₁ | ΔC₂₂ | ΔC₃₃ (paired by seed, n) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, d, failed in variants:
        seeds = sorted(d)
        n = f"{len(seeds)}" + (f" ({failed} failed)" if failed else "")
        if not seeds:
            print(f"| {name} | {n} | " + " | ".join(["—"] * 11) + " |")
            continue
        cells = []
        for k in ["C11", "C12", "C22", "C33"]:
            cells.append(fmt(*mean_std([d[s][k] for s in seeds]), k))
        cells.append(f"{mean_std([d[s]['C33'] for s in seeds])[0] / pub['C33']:.2f}")
        for k in ["phi2", "z_star", "preparation_steps"]:
            cells.append(fmt(*mean_std([d[s][k] for s in seeds]), k))
        common = [s for s in seeds if s in base]
        for k in ["C11", "C22", "C33"]:
            if name == "baseline" or len(common) < 2:
                cells.append("—")
                continue
            rel = [d[s][k] / base[s][k] - 1 for s in common]
            m, sd = mean_std(rel)
            se = sd / math.sqrt(len(rel))
            mark = " *" if abs(m) > 2 * se else ""
            cells.append(f"{100 * m:+.0f} ± {100 * se:.0f} %{mark}" + (f" ({len(rel)})" if k == "C33" else ""))
        print(f"| {name} | {n} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
