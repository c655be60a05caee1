#!/usr/bin/env python3
"""E1 amplitude and width exponents under the second definition of the first-peak metrics.

Usage:
    python3 examples/papers/e1-exponents-definitions.py RUN_DIR [--replicates 1000] [--seed 1]

RUN_DIR is a run of examples/papers/e1-exponents.toml (or any E1 run with several heights at one
pressure). grainwave reports γ and α from the first peak of the **ensemble-averaged** signal at each
height (SPEC §5.5, "the first (coherent) peak of F_sig"; summary.json `heights[].series` and
`exponent_intervals`). The published study does not say whether it measured the peak of the mean
signal or averaged the peaks of the individual signals; the two differ because arrival times
scatter from sample to sample (the mean signal is lower and wider than the typical signal, more so
at larger L). This script computes the second definition from samples.csv — the per-sample peak
amplitude A_i, width W_i (leading edge → first zero crossing) and FWHM_i of each sample's own first
peak — and fits

    ⟨A⟩(L) ∼ L^−γ,  ⟨W⟩(L) ∼ L^α,  ⟨FWHM⟩(L) ∼ L^α_FWHM

by least squares in log–log over the heights (⟨·⟩ = mean over the samples of a height, L its mean
height), with 95 % percentile intervals from a bootstrap over the samples of each height
(resampled independently per height, as grainwave's own intervals are), and the effective
exponents d ln⟨A⟩ / d ln L between successive heights with their intervals. It prints the mean-
signal exponents of summary.json beside them for comparison. Nothing is fitted to a published
number. Standard library only.
"""
import csv
import json
import math
import os
import random
import sys


def fit_slope(xs, ys):
    """Least-squares slope of ln y against ln x."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    n = len(lx)
    mx, my = sum(lx) / n, sum(ly) / n
    sxx = sum((a - mx) ** 2 for a in lx)
    sxy = sum((a - mx) * (b - my) for a, b in zip(lx, ly))
    return sxy / sxx


def percentile(sorted_values, q):
    """Linear-interpolated percentile of an already sorted list (q in [0, 1])."""
    k = (len(sorted_values) - 1) * q
    lo, hi = math.floor(k), math.ceil(k)
    return sorted_values[lo] + (sorted_values[hi] - sorted_values[lo]) * (k - lo)


def main(argv):
    args, opts, k = [], {}, 0
    while k < len(argv):
        if argv[k] in ("--replicates", "--seed") and k + 1 < len(argv):
            opts[argv[k]] = argv[k + 1]
            k += 2
        elif argv[k].startswith("--"):
            sys.exit(f"unknown option {argv[k]!r} (allowed: --replicates N, --seed S)")
        else:
            args.append(argv[k])
            k += 1
    if len(args) < 1:
        sys.exit(__doc__)
    run = args[0]
    replicates = int(opts.get("--replicates", 1000))
    rng = random.Random(int(opts.get("--seed", 1)))
    rows = []
    with open(os.path.join(run, "samples.csv"), newline="") as f:
        for r in csv.DictReader(f):
            if r["failure"] or not r["peak_amplitude"]:
                continue
            rows.append(r)
    groups = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(
            (float(r["height"]), float(r["peak_amplitude"]), float(r["width"]), float(r["fwhm"]))
        )
    # heights in increasing order of their mean L; at least two samples each
    series = sorted((sum(s[0] for s in v) / len(v), k, v) for k, v in groups.items() if len(v) >= 2)
    if len(series) < 2:
        sys.exit(f"{run}: fewer than two heights with two or more samples")
    names = [k for _, k, _ in series]
    samples = [v for _, _, v in series]

    def point(picks):
        out = []
        for v, pick in zip(samples, picks):
            sel = [v[i] for i in pick]
            out.append(tuple(sum(s[c] for s in sel) / len(sel) for c in range(4)))
        return out

    def exponents(pts):
        ls = [p[0] for p in pts]
        fits = [-fit_slope(ls, [p[1] for p in pts]), fit_slope(ls, [p[2] for p in pts]), fit_slope(ls, [p[3] for p in pts])]
        eff = []
        for a, b in zip(pts, pts[1:]):
            dl = math.log(b[0] / a[0])
            eff.append([-math.log(b[1] / a[1]) / dl, math.log(b[2] / a[2]) / dl, math.log(b[3] / a[3]) / dl])
        return fits, eff

    full = point([list(range(len(v))) for v in samples])
    fits, eff = exponents(full)
    reps_fit = [[] for _ in range(3)]
    reps_eff = [[[] for _ in range(3)] for _ in eff]
    for _ in range(replicates):
        picks = [[rng.randrange(len(v)) for _ in range(len(v))] for v in samples]
        f, e = exponents(point(picks))
        for c in range(3):
            reps_fit[c].append(f[c])
            for k in range(len(e)):
                reps_eff[k][c].append(e[k][c])

    def interval(values):
        s = sorted(values)
        return percentile(s, 0.025), percentile(s, 0.975)

    print(f"{run}: {len(rows)} samples at {len(series)} heights ({', '.join(f'{n}: {len(v)}' for n, v in zip(names, samples))})")
    print("per-sample first peaks, averaged over the samples of each height (second definition):")
    print("  L       <A>          <W>       <FWHM>")
    for p in full:
        print(f"  {p[0]:6.2f}  {p[1]:.4e}  {p[2]:8.3f}  {p[3]:8.3f}")
    labels = ["γ (amplitude)", "α (width)", "α (FWHM)"]
    for c in range(3):
        lo, hi = interval(reps_fit[c])
        print(f"  {labels[c]:14s} = {fits[c]:.3f}  95 % interval [{lo:.3f}, {hi:.3f}]  ({replicates} replicates)")
    print("  effective exponents between successive heights:")
    for k, (a, b) in enumerate(zip(full, full[1:])):
        parts = []
        for c in range(3):
            lo, hi = interval(reps_eff[k][c])
            parts.append(f"{labels[c].split()[0]} {eff[k][c]:.2f} [{lo:.2f}, {hi:.2f}]")
        print(f"    L {a[0]:5.1f} → {b[0]:5.1f}: " + ", ".join(parts))
    summary = os.path.join(run, "summary.json")
    if os.path.exists(summary):
        with open(summary) as f:
            s = json.load(f)
        for h in s.get("heights", []):
            ei = h.get("exponent_intervals")
            if not ei:
                continue
            print("mean-signal first peak (grainwave's definition, summary.json):")
            for key, label in (("gamma", "γ (amplitude)"), ("alpha", "α (width)"), ("alpha_fwhm", "α (FWHM)")):
                v = ei.get(key)
                if v:
                    print(f"  {label:14s} = {v['estimate']:.3f}  95 % interval [{v['low']:.3f}, {v['high']:.3f}]")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
