#!/usr/bin/env python3
"""E2 with the slip-activation friction law (docs/e2.md, "Slip activation"): the τ sweep's table
and figure, from the committed per-run data in docs/data/e2-slip-activation/.

    python3 examples/papers/e2-slip-activation.py                 # the table (markdown)
    python3 examples/papers/e2-slip-activation.py --csv FILE      # the same rows as CSV
    python3 examples/papers/e2-slip-activation.py --plot FILE.png # stress–strain and c(±) against τ (matplotlib)
    python3 examples/papers/e2-slip-activation.py --amplitude 1e-8

Each run directory `<size>-tau<τ>[-seed<N>]` (no suffix: seed 1; τ = 0 is the reference) holds summary.json and
stress_strain.csv (the loading's strain checkpoints: strain_yy, stress_yy, stress_xx [p*],
sliding). Pulse speeds c/v_a by SPEC §6.5's arrival (time of the maximum of |δv_x|, the headline)
and by the first lobe (labelled); losses Δc/c₀ positive, c₀ the undeformed speed of the same
amplitude and sign. "sign gap" = (c(+) − c(−))/c₀ of a state: the paper's sign dependence.
Beside the static state's DEM speeds, its exact incremental limits (incremental.csv, the e2
`incremental` replay with `source.dir` the run): the Coulomb branch rule at p_a → 0± (the τ = 0
law's limit) and the all-stick network (the limit of pulses much shorter than τ).
Standard library only (matplotlib for --plot).
"""
import csv
import json
import math
import os
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
DATA = os.path.join(ROOT, "docs", "data", "e2-slip-activation")
DEFINITIONS = {"maximum": "speed_maximum", "first lobe": "speed_first_lobe"}


def runs(data=DATA):
    """(size, τ, seed, directory) of every run `<size>-tau<τ>[-seed<N>]` (no suffix: seed 1),
    sorted by size, τ and seed."""
    out = []
    for d in os.listdir(data) if os.path.isdir(data) else []:
        if "-tau" in d and os.path.exists(os.path.join(data, d, "summary.json")):
            size, rest = d.split("-tau", 1)
            tau, _, seed = rest.partition("-seed")
            out.append((int(size), float(tau), int(seed or 1), os.path.join(data, d)))
    return sorted(out)


def stats(xs):
    """(mean, SE, n) over the values that are not None."""
    xs = [x for x in xs if x is not None]
    n = len(xs)
    if n == 0:
        return None, None, 0
    m = sum(xs) / n
    se = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1) / n) if n > 1 else None
    return m, se, n


def front(c):
    """A speed, or None where the strip fit found no front (no positive slope)."""
    return c if c is not None and c > 0 else None


def speeds(summary, key):
    out = {}
    for r in summary["replays"]:
        for p in r.get("pairs") or []:
            out[(r["name"], p["amplitude"])] = front(p.get(key))
    return out


def mobilised(summary, name):
    """M_s (contacts at the Coulomb limit) at the start of replay `name`'s first pair."""
    for r in summary["replays"]:
        if r["name"] == name and r.get("pairs"):
            return r["pairs"][0]["mobilised"][0]
    return None


def row(size, tau, d, amp, key):
    s = json.load(open(os.path.join(d, "summary.json")))
    sp = speeds(s, key)
    c = lambda name, a: sp.get((name, a))
    rel = lambda a, b, c0: None if a is None or b is None or c0 is None else (a - b) / c0
    out = {"size": size, "tau": tau, "peak_stress_ratio": s["loading"]["peak_stress_ratio"],
           "final_stress_yy": s["loading"]["final_stress_yy"], "final_stress_xx": s["loading"]["final_stress_xx"],
           "loading_sliding": s["loading"]["final_sliding"], "static_mobilised": mobilised(s, "static")}
    for sign, a in (("+", amp), ("-", -amp)):
        c0 = c("undeformed", a)
        out[f"undeformed{sign}"] = c0
        out[f"nonsliding{sign}"] = c("nonsliding", a)
        out[f"static{sign}"] = c("static", a)
        out[f"deforming{sign}"] = c("deforming", a)
        out[f"contact_loss{sign}"] = rel(c0, c("nonsliding", a), c0)
        out[f"sliding{sign}"] = rel(c("nonsliding", a), c("static", a), c0)
        out[f"strain_rate{sign}"] = rel(c("static", a), c("deforming", a), c0)
        out[f"static_wavelet{sign}"] = c("static_wavelet", 1e-6 if sign == "+" else -1e-6)
        out[f"deforming_wavelet{sign}"] = c("deforming_wavelet", 1e-6 if sign == "+" else -1e-6)
    # the exact incremental limits of the static state (docs/e2.md, "The incremental limit"):
    # every contact at the Coulomb limit slipping while pushed on (the τ = 0 law's p_a → 0±), and
    # every contact sticking (the limit of a pulse much shorter than τ)
    inc = {}
    f = os.path.join(d, "incremental.csv")
    if os.path.exists(f):
        for r in csv.DictReader(open(f)):
            v = r[key]
            inc[(r["replay"], float(r["amplitude"]))] = front(float(v)) if v else None
    out["incremental+"] = inc.get(("incremental", 1.0))
    out["incremental-"] = inc.get(("incremental", -1.0))
    out["stick"] = inc.get(("stick", 1.0))
    c0 = out["undeformed+"]
    out["static_sign_gap"] = rel(out["static+"], out["static-"], c0)
    out["deforming_sign_gap"] = rel(out["deforming+"], out["deforming-"], c0)
    out["static_wavelet_sign_gap"] = rel(out["static_wavelet+"], out["static_wavelet-"], c0)
    out["seconds"] = s.get("wall_seconds")
    return out


def fmt(x, digits=3):
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


COLUMNS = [
    ("σ_yy/σ_xx peak", ["peak_stress_ratio"]),
    ("M_s loading end", ["loading_sliding"]),
    ("M_s static", ["static_mobilised"]),
    ("c static (+ / −)", ["static+", "static-"]),
    ("sign gap static", ["static_sign_gap"]),
    ("static, exact incremental limit: Coulomb rule (+ / −)", ["incremental+", "incremental-"]),
    ("static, all-stick limit", ["stick"]),
    ("c deforming (+ / −)", ["deforming+", "deforming-"]),
    ("sign gap deforming", ["deforming_sign_gap"]),
    ("sliding loss (+ / −)", ["sliding+", "sliding-"]),
    ("contact loss (+ / −)", ["contact_loss+", "contact_loss-"]),
    ("wavelet static (+ / −)", ["static_wavelet+", "static_wavelet-"]),
]


def cell(values):
    m, se, n = stats(values)
    if m is None:
        return "—"
    digits = 0 if all(isinstance(v, int) for v in values if v is not None) else 3
    return f"{m:.{digits}f}" + (f" ± {se:.{digits}f}" if se is not None else "")


def table(amp, key, data=DATA):
    """Per (size, τ): mean ± SE over the packings (seeds) of each column."""
    rows = [dict(row(size, tau, d, amp, key), seed=seed) for size, tau, seed, d in runs(data)]
    lines = [
        f"|p_a| = {amp:g} t* (δ pulses), wavelets of peak 1e-6; speeds c/v_a by the {key.replace('speed_', '').replace('_', ' ')} arrival; mean ± SE over the packings (n)",
        "",
        "| N | τ [t_a] | n | " + " | ".join(c for c, _ in COLUMNS) + " |",
        "|" + "---|" * (3 + len(COLUMNS)),
    ]
    for size, tau in sorted({(r["size"], r["tau"]) for r in rows}):
        group = [r for r in rows if r["size"] == size and r["tau"] == tau]
        cells = [" / ".join(cell([r[k] for r in group]) for k in keys) for _, keys in COLUMNS]
        lines.append(f"| {size}² | {tau:g} | {len(group)} | " + " | ".join(cells) + " |")
    return rows, "\n".join(lines)


def plot(path, amp, data=DATA):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    rs = runs(data)
    for size, tau, seed, d in rs:
        f = os.path.join(d, "stress_strain.csv")
        if seed != 1 or not os.path.exists(f):
            continue
        pts = [(float(r["strain_yy"]), float(r["stress_yy"]) / float(r["stress_xx"])) for r in csv.DictReader(open(f)) if float(r["stress_xx"]) > 0]
        a1.plot([p[0] * 100 for p in pts], [p[1] for p in pts], label=f"{size}², τ = {tau:g} t_a", lw=1)
    a1.set_xlabel("ε_yy [%]")
    a1.set_ylabel("σ_yy / σ_xx")
    a1.set_title("loading (compression)")
    a1.legend(fontsize=7)
    for size in sorted({r[0] for r in rs}):
        taus = sorted({t for s, t, _, _ in rs if s == size})
        # τ = 0 drawn at the left edge of the log axis
        tmin = min([t for t in taus if t > 0] or [1.0]) / 10
        for state, style in (("static", "-"), ("deforming", "--")):
            for sign, marker in (("+", "o"), ("-", "v")):
                xs, ys, es = [], [], []
                for t in taus:
                    m, se, n = stats([row(size, t, d, amp, "speed_maximum")[f"{state}{sign}"] for s, tt, _, d in rs if s == size and tt == t])
                    if m is not None:
                        xs.append(t if t > 0 else tmin)
                        ys.append(m)
                        es.append(se or 0.0)
                a2.errorbar(xs, ys, yerr=es, fmt=style, marker=marker, label=f"{size}² {state} p_a {sign}", lw=1, ms=4, capsize=2)
        xs, ys = [], []
        for t in taus:
            m, _, _ = stats([row(size, t, d, amp, "speed_maximum")["stick"] for s, tt, _, d in rs if s == size and tt == t])
            if m is not None:
                xs.append(t if t > 0 else tmin)
                ys.append(m)
        a2.plot(xs, ys, ":", color="black", marker="s", ms=3, lw=1, label=f"{size}² static, exact all-stick limit")
    a2.set_xscale("log")
    a2.set_xlabel("τ [t_a] (leftmost point: τ = 0, the Coulomb law)")
    a2.set_ylabel("c / v_a (SPEC arrival)")
    a2.set_title(f"pulse speed, |p_a| = {amp:g} t*")
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv):
    amp, key, csv_out, plot_out = 1e-9, None, None, None
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--amplitude":
            amp = float(argv[i + 1]); i += 2
        elif a == "--csv":
            csv_out = argv[i + 1]; i += 2
        elif a == "--plot":
            plot_out = argv[i + 1]; i += 2
        else:
            sys.exit(f"unknown argument {a!r} (allowed: --amplitude A, --csv FILE, --plot FILE)")
    if not runs():
        sys.exit(f"no runs under {os.path.relpath(DATA, ROOT)}")
    if plot_out:
        plot(plot_out, amp)
        return
    all_rows = []
    for name, key in DEFINITIONS.items():
        rows, text = table(amp, key)
        print(("**SPEC arrival (maximum of |δv_x|), the headline**" if name == "maximum" else "**First-lobe arrival (the replays' own, labelled alternative)**") + "\n")
        print(text + "\n")
        for r in rows:
            r["arrival"] = name
        all_rows += rows
    if csv_out:
        with open(csv_out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=["arrival", "size", "tau", "seed"] + [k for k in all_rows[0] if k not in ("arrival", "size", "tau", "seed")])
            w.writeheader()
            for r in all_rows:
                w.writerow({k: ("" if v is None else v) for k, v in r.items()})


if __name__ == "__main__":
    main(sys.argv[1:])
