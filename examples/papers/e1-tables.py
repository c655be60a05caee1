#!/usr/bin/env python3
"""E1 Tables I–II (static characterization and moduli, SPEC §5.2–5.3) per pressure from a run's
samples.csv, beside the published values: mean ± standard deviation over the samples (n), the
moduli over the published ones, and the preparation's cost.

    python3 examples/papers/e1-tables.py docs/data/e1-tables      # or any E1 run directory

Standard library only.
"""
import csv
import math
import os
import sys

TABLE1 = {  # Φ₂, Φ₃, Φ₃*, z*, f₀ %, ⟨N/p⟩, Z(2), Z(3), F₂, F₂^S
    1e-7: ["0.818", "0.561", "0.48", "3.18", "15", "1.31", "1.49", "2.81", "0.527", "0.557"],
    1e-6: ["0.814", "0.558", "0.49", "3.23", "14", "1.27", "1.50", "2.83", "0.524", "0.560"],
    1e-5: ["0.809", "0.554", "0.50", "3.31", "11", "1.22", "1.49", "2.77", "0.523", "0.558"],
    1e-4: ["0.815", "0.558", "0.52", "3.48", "7.4", "1.06", "1.51", "2.90", "0.524", "0.578"],
}
COLS1 = [("phi2", 1, 4), ("phi3", 1, 4), ("phi3_star", 1, 4), ("z_star", 1, 3), ("f0", 100, 2),
         ("mean_force_over_p", 1, 3), ("Z2", 1, 3), ("Z3", 1, 3), ("F2", 1, 4), ("F2_strong", 1, 4)]
TABLE2 = {  # σ₁/σ₂, C₁₁, C₁₂, C₂₂, C₃₃
    1e-7: ["0.79", "9.9e-4", "8.1e-4", "13.9e-4", "1.2e-4"],
    1e-6: ["0.79", "2.3e-3", "1.7e-3", "3.2e-3", "0.35e-3"],
    1e-5: ["0.78", "5.4e-3", "3.5e-3", "7.4e-3", "1.1e-3"],
    1e-4: ["0.71", "1.35e-2", "6.8e-3", "1.88e-2", "4.0e-3"],
}


def ms(xs):
    n = len(xs)
    m = sum(xs) / n
    return m, math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1)) if n > 1 else float("nan")


def main(argv):
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    with open(os.path.join(argv[0], "samples.csv"), newline="") as f:
        rows = [r for r in csv.DictReader(f) if not r.get("failure")]
    by = {}
    for r in rows:
        by.setdefault(float(r["pressure"]), []).append(r)
    print("| p | | Φ₂ | Φ₃ | Φ₃* | z* | f₀ % | ⟨N/p⟩ | Z(2) | Z(3) | F₂ | F₂^S |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for p in sorted(by):
        if p in TABLE1:
            print(f"| {p:g} | published | " + " | ".join(TABLE1[p]) + " |")
        cells = []
        for key, scale, d in COLS1:
            m, s = ms([float(r[key]) * scale for r in by[p]])
            cells.append(f"{m:.{d}f} ± {s:.{d}f}")
        print(f"| | ours ({len(by[p])}) | " + " | ".join(cells) + " |")
    print()
    print("| p | | σ₁/σ₂ | C₁₁ | C₁₂ | C₂₂ | C₃₃ | C₃₃ / published | C₂₂ / published | preparation steps | seconds per packing |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for p in sorted(by):
        pub = TABLE2.get(p)
        if pub:
            print(f"| {p:g} | published | " + " | ".join(pub) + " | | | | |")
        m, s = ms([float(r["sigma_ratio"]) for r in by[p]])
        cells = [f"{m:.3f} ± {s:.3f}"]
        means = {}
        for key in ["C11", "C12", "C22", "C33"]:
            m, s = ms([float(r[key]) for r in by[p]])
            means[key] = m
            cells.append(f"{m:.3g} ± {s:.2g}")
        ratio = (lambda k, i: f"{means[k] / float(pub[i]):.2f}") if pub else (lambda k, i: "—")
        st = ms([float(r["preparation_steps"]) for r in by[p]])
        sec = ms([float(r["seconds"]) for r in by[p]])
        print(f"| | ours ({len(by[p])}) | " + " | ".join(cells) +
              f" | {ratio('C33', 4)} | {ratio('C22', 3)} | {st[0] / 1e3:.0f} k ± {st[1] / 1e3:.0f} k | {sec[0]:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
