#!/usr/bin/env python3
"""E2: how stopped is "static"? The residual-drive series and the amplitude series (docs/e2.md,
"How stopped is static?"), per packing and over packings, from the summaries of runs of
examples/papers/e2-{compression,extension}-64.toml (the replays `slow4`, `slow5`,
`stop500_g3_r0/_r10/_r30`, `drive_*`, `amplitude_*`).

    python3 examples/papers/e2-residual-drive.py                  # every run in docs/data/e2-64 that has them
    python3 examples/papers/e2-residual-drive.py DIR [DIR ...]    # any run directories (summary.json)
    python3 examples/papers/e2-residual-drive.py --csv OUTDIR     # also residual_drive.csv, amplitude_series.csv
    python3 examples/papers/e2-residual-drive.py --plot FILE.png  # the figure (needs matplotlib)
    python3 examples/papers/e2-residual-drive.py --brief          # one table per direction (the page's)
    python3 examples/papers/e2-residual-drive.py --split A.csv B.csv …  # sums e2_contact_state splits

Residual drive: states stopped to different degrees — the deforming state (the loading at
2e-5/t*), the γ = 0.001 slow-down `slow3` (still loaded at 2e-8/t*) and its continuations to 2e-9
and 2e-10/t*, the t_s = 500 t_a stop followed by 0, 10, 30 and 100 t_a of radiation (100 t_a is the
canonical static state), and the canonical chain's other stops. For each: the top wall's strain rate,
the kinetic energy and M_s (cap flag and mobilised) at the state, σ_yy, and the decomposition of
the pulse-speed loss against the same packing's undeformed (c₀) and non-sliding (c_ns) states,
sliding = (c_ns − c)/c₀ and (c − c_d)/c₀ against the deforming state, for δ pulses of both signs.

Amplitude series: per state and sign, the fraction of the contacts mobilised before the pulse
that the pulse released, R = (M_s(end without) − M_s(end with)) / M_s(start) (mobilised count,
|F_t| ≥ (1 − 1e-6) μ F_n), the largest cap-flag difference during the replay, and the speed.

Arrival definitions (SPEC §6.5): "maximum" = the time of the maximum of |δv_x| (SPEC's headline),
"first lobe" = the first lobe of the front. Losses are written positive. Means ± standard error over
the packings. Standard library only (matplotlib for --plot).
"""
import csv
import glob
import json
import math
import os
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
# (state label, the single replay that made it, the wall-pulse replays on it, nominal wall rate [1/t*])
STATES = [
    ("deforming (the loading)", None, ["deforming", "amplitude_deforming"], None),
    ("slow3, loaded at 2e-8/t*", "slow3", ["drive_slow3"], 2e-8),
    ("slow4, loaded at 2e-9/t*", "slow4", ["drive_slow4"], 2e-9),
    ("slow5, loaded at 2e-10/t*", "slow5", ["drive_slow5"], 2e-10),
    ("stopped (t_s = 500 t_a) + 0 t_a", "stop500_g3_r0", ["drive_r0"], 0.0),
    ("stopped + 10 t_a", "stop500_g3_r10", ["drive_r10"], 0.0),
    ("stopped + 30 t_a", "stop500_g3_r30", ["drive_r30"], 0.0),
    ("stopped + 100 t_a (static)", "stop500_g3", ["static", "amplitude_static"], 0.0),
    ("t_s = 50 t_a + 100 t_a", "stop50_g3", ["static_ts50"], 0.0),
    ("t_s = 5 t_a + 100 t_a", "stop5_g3", ["static_ts5"], 0.0),
    ("from γ = 0.01 (2e-7/t*), t_s = 500", "stop500_g2", ["static_g2"], 0.0),
    ("from γ = 0.1 (2e-6/t*), t_s = 500", "stop500_g1", ["static_g1"], 0.0),
]
DRIVE_AMPS = [1e-10, 1e-9, 1e-8]
# the published sliding losses at |p_a| = 1e-9 (VALIDATION.md, E2), p_a > 0 and p_a < 0
PUBLISHED_SLIDING = {"compression": (0.179, 0.260), "extension": (0.107, 0.090)}
KEYS = {"maximum": "speed_maximum", "first lobe": "speed_first_lobe"}


def load(d):
    with open(os.path.join(d, "summary.json")) as f:
        s = json.load(f)
    # the loading rate, from the run's resolved config (the deforming state's wall rate)
    s["_loading_rate"] = None
    cfg = os.path.join(d, "config.resolved.toml")
    if os.path.exists(cfg):
        section = None
        for line in open(cfg):
            line = line.split("#")[0].strip()
            if line.startswith("["):
                section = line.strip("[]")
            elif section == "loading" and line.startswith("strain_rate"):
                s["_loading_rate"] = float(line.split("=")[1])
    return s


def has_drive(s):
    return any(r["name"] == "drive_r0" for r in s["replays"])


def replay(s, name):
    return next((r for r in s["replays"] if r["name"] == name), None)


def speed(s, names, amp, key):
    for n in names:
        r = replay(s, n)
        if r is None:
            continue
        for p in r["pairs"]:
            if p["amplitude"] == amp and p.get(key) is not None:
                # a fitted speed that is not positive is no front (see e2-table2.py, front())
                return p[key] if p[key] > 0 else None
    return None


def pulse_row(s, names, amp):
    for p in s["pulses"]:
        if p["replay"] in names and p["amplitude"] == amp:
            return p
    return None


def stats(xs):
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    n = len(xs)
    if n == 0:
        return None, None, 0
    m = sum(xs) / n
    se = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1)) / math.sqrt(n) if n > 1 else float("nan")
    return m, se, n


def fmt(m, se=None, digits=3):
    if m is None:
        return "—"
    if se is None or not math.isfinite(se):
        return f"{m:.{digits}f}"
    return f"{m:.{digits}f} ± {se:.{digits}f}"


def drive_rows(name, s):
    """Per state of one packing: wall rate, KE, M_s, σ_yy, and the losses at each amplitude."""
    rows = []
    for label, single, pulses, rate in STATES:
        if rate is None:
            rate = s.get("_loading_rate")
        info = {"packing": name, "direction": s["loading"]["direction"] if s.get("loading") else "", "state": label, "wall_rate": rate}
        if single is not None:
            r = replay(s, single)
            if r is None or r.get("single") is None:
                continue
            one = r["single"]
            info.update(kinetic_energy=one["kinetic_energy"][1], flagged=one["sliding"][1], mobilised=one["mobilised"][1],
                        stress_yy=one["final_stress_yy"], duration_ta=one["duration"])
        else:
            p = pulse_row(s, pulses, DRIVE_AMPS[0])
            if p is None:
                continue
            info.update(kinetic_energy=None, flagged=p["flagged"][0], mobilised=p["mobilised"][0],
                        stress_yy=s["loading"]["final_stress_yy"], duration_ta=None)
        for amp in DRIVE_AMPS:
            for sign in (1, -1):
                a = sign * amp
                for label_k, key in KEYS.items():
                    c0 = speed(s, ["undeformed"], a, key)
                    cns = speed(s, ["nonsliding"], a, key)
                    cd = speed(s, ["deforming"], a, key)
                    c = speed(s, pulses, a, key)
                    tag = f"{a:g}|{label_k}"
                    info[f"speed|{tag}"] = c
                    # the sliding loss does not need the deforming state (which may have no
                    # front by the maximum); the rate term does
                    info[f"sliding|{tag}"] = None if None in (c0, cns, c) else (cns - c) / c0
                    info[f"rate|{tag}"] = None if None in (c0, cd, c) else (c - cd) / c0
        rows.append(info)
    return rows


def amplitude_rows(name, s):
    rows = []
    for label, _, pulses, _ in STATES:
        for p in s["pulses"]:
            if p["replay"] not in pulses:
                continue
            start, with_, without = p["mobilised"]
            rows.append({
                "packing": name, "direction": s["loading"]["direction"] if s.get("loading") else "", "state": label,
                "replay": p["replay"], "amplitude": p["amplitude"],
                "mobilised_start": start, "mobilised_end_with": with_, "mobilised_end_without": without,
                "released": (without - with_) / start if start else None,
                "flagged_start": p["flagged"][0], "max_flagged_difference": p["max_sliding_difference"],
                "speed_maximum": speed(s, [p["replay"]], p["amplitude"], "speed_maximum"),
                "speed_first_lobe": speed(s, [p["replay"]], p["amplitude"], "speed_first_lobe"),
            })
    return rows


def state_cells(sel):
    """The wall rate, KE and M_s (flagged / mobilised) cells of one state's rows (means over packings)."""
    ke = stats([r.get("kinetic_energy") for r in sel])[0]
    fl = stats([r.get("flagged") for r in sel])[0]
    mo = stats([r.get("mobilised") for r in sel])[0]
    rate = sel[0]["wall_rate"]
    return f"{'—' if rate is None else f'{rate:g}'} | {'—' if ke is None else f'{ke:.1e}'} | {fl:.0f} / {mo:.0f}"


def loss_cell(sel, kind, amp, label):
    """Mean ± SE of a loss over the packings, p_a > 0 / p_a < 0."""
    p = stats([r.get(f"{kind}|{amp:g}|{label}") for r in sel])
    m = stats([r.get(f"{kind}|{-amp:g}|{label}") for r in sel])
    return f"{fmt(p[0], p[1])} / {fmt(m[0], m[1])}"


def print_drive(direction, rows, amp):
    states = [st[0] for st in STATES]
    print(f"### {direction}: residual drive, sliding loss (c_ns − c)/c₀ at |p_a| = {amp:g} t*, p_a > 0 / p_a < 0\n")
    n = len({r["packing"] for r in rows})
    print(f"Means ± SE over {n} packing(s). KE in p* L*², M_s flagged / mobilised at the state.\n")
    print("| state | wall rate [1/t*] | KE | M_s flagged / mobilised | σ_yy [p*] | sliding, maximum | sliding, first lobe | (c − c_d)/c₀, maximum |")
    print("|---|---|---|---|---|---|---|---|")
    for st in states:
        sel = [r for r in rows if r["state"] == st]
        if not sel:
            continue
        sy = stats([r.get("stress_yy") for r in sel])[0]
        cells = [loss_cell(sel, kind, amp, label) for kind, label in (("sliding", "maximum"), ("sliding", "first lobe"), ("rate", "maximum"))]
        print(f"| {st} | {state_cells(sel)} | {sy:.7f} | " + " | ".join(cells) + " |")
    print()


def print_brief(direction, rows):
    """One row per state: KE, M_s, and the sliding loss at |p_a| = 1e-10, 1e-9, 1e-8 by SPEC's arrival."""
    n = len({r["packing"] for r in rows})
    print(f"### {direction}: sliding loss (c_ns − c)/c₀ by SPEC's arrival (maximum of |δv_x|), p_a > 0 / p_a < 0, mean ± SE over {n} packing(s)\n")
    print("| state | wall rate [1/t*] | KE [p* L*²] | M_s flagged / mobilised | \\|p_a\\| = 1e-10 | 1e-9 | 1e-8 |")
    print("|---|---|---|---|---|---|---|")
    for st in [s[0] for s in STATES]:
        sel = [r for r in rows if r["state"] == st]
        if not sel:
            continue
        cells = [loss_cell(sel, "sliding", amp, "maximum") for amp in DRIVE_AMPS]
        print(f"| {st} | {state_cells(sel)} | " + " | ".join(cells) + " |")
    print()


def print_amplitudes(direction, rows):
    print(f"### {direction}: released fraction R of M_s (mobilised) by pulse amplitude, p_a > 0 / p_a < 0\n")
    amps = sorted({abs(r["amplitude"]) for r in rows})
    states = []
    for r in rows:
        if r["state"] not in states:
            states.append(r["state"])
    print("| state | " + " | ".join(f"{a:g}" for a in amps) + " |")
    print("|---|" + "---|" * len(amps))
    for st in states:
        cells = []
        for a in amps:
            p = stats([r["released"] for r in rows if r["state"] == st and r["amplitude"] == a])
            m = stats([r["released"] for r in rows if r["state"] == st and r["amplitude"] == -a])
            cells.append("—" if p[0] is None and m[0] is None else f"{fmt(p[0])} / {fmt(m[0])}")
        print(f"| {st} | " + " | ".join(cells) + " |")
    print()


def write_csv(path, rows):
    keys = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in keys})


def plot(path, drive, amplitude):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    order = [st[0] for st in STATES][:8]
    for col, direction in enumerate(("compression", "extension")):
        ax = axes[0][col]
        sel = [r for r in drive if r["direction"] == direction]
        for amp, style in ((1e-9, "-"), (1e-10, ":")):
            for sign, colour in ((1, "tab:red"), (-1, "tab:blue")):
                xs, ys, es = [], [], []
                for k, st in enumerate(order):
                    m, se, n = stats([r.get(f"sliding|{sign * amp:g}|maximum") for r in sel if r["state"] == st])
                    if m is not None:
                        xs.append(k)
                        ys.append(m)
                        es.append(se if se is not None and math.isfinite(se) else 0.0)
                if xs:
                    ax.errorbar(xs, ys, yerr=es, fmt="o" + style, color=colour, capsize=3,
                                label=f"p_a = {sign * amp:g}")
        for value, colour, sign in zip(PUBLISHED_SLIDING[direction], ("tab:red", "tab:blue"), ("+", "−")):
            ax.axhline(value, color=colour, lw=0.8, ls="--", alpha=0.6)
            ax.annotate(f"published (128², static), p_a {sign}", (len(order) - 1, value), fontsize=7, color=colour,
                        ha="right", va="bottom")
        ax.set_xticks(range(len(order)))
        ax.set_xticklabels([o.split(",")[0].replace(" (static)", "\n(static)") for o in order], rotation=35, ha="right", fontsize=8)
        ax.set_ylabel("sliding loss (c_ns − c)/c₀ (arrival: maximum)")
        ax.set_title(f"{direction}: from loaded to stopped")
        ax.axhline(0, color="grey", lw=0.5)
        ax.legend(fontsize=8)
        ax = axes[1][col]
        sel = [r for r in amplitude if r["direction"] == direction]
        for st, colour in ((STATES[0][0], "tab:green"), (STATES[4][0], "tab:orange"), (STATES[7][0], "tab:purple")):
            for sign, style in ((1, "-"), (-1, "--")):
                amps = sorted({abs(r["amplitude"]) for r in sel if r["state"] == st})
                xs, ys = [], []
                for a in amps:
                    m = stats([r["released"] for r in sel if r["state"] == st and r["amplitude"] == sign * a])[0]
                    if m is not None:
                        xs.append(a)
                        ys.append(m)
                if xs:
                    ax.plot(xs, ys, style, marker="o", color=colour, label=f"{st.split(' (')[0]}, {'+' if sign > 0 else '−'}")
        ax.set_xscale("log")
        ax.set_xlabel("|p_a| [t*]")
        ax.set_ylabel("released fraction of M_s")
        ax.set_title(f"{direction}: contacts a pulse releases")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def print_split(paths):
    """Sums the per-bin counts of `e2_contact_state` split files (E2_SPLIT_CSV) over packings."""
    total, slid_cols = {}, None
    for path in paths:
        with open(path) as f:
            for r in csv.DictReader(f):
                cols = [c for c in r if c.startswith("slid_")]
                slid_cols = slid_cols or cols
                key = (r["split"], int(r["bin"]), r["from"], r["to"])
                t = total.setdefault(key, [0] * (4 + len(cols)))
                for i, c in enumerate(["contacts", "mobilised", "pushed_on_compression", "pushed_on_rarefaction"] + cols):
                    t[i] += int(r[c])
    print(f"Sum over {len(paths)} state(s). Shares: mobilised of the contacts; pushed on of the mobilised; slid of the contacts.\n")
    head = "| split | bin | contacts | mobilised | pushed on, p_a > 0 / < 0 | " + " | ".join(f"slid, p_a = {c[5:]}" for c in slid_cols or []) + " |"
    print(head)
    print("|---" * (5 + len(slid_cols or [])) + "|")
    for (kind, b, lo, hi), v in sorted(total.items()):
        unit = "" if kind == "distance" else "°"
        span = f"{float(lo):g}–{float(hi):g}{unit}" + (" of the box from the pulsing wall" if kind == "distance" and b == 0 else "")
        mob = v[1] or 1
        cells = [f"{v[4 + i]} ({100 * v[4 + i] / max(v[0], 1):.1f} %)" for i in range(len(slid_cols or []))]
        print(f"| {kind} | {span} | {v[0]} | {v[1]} ({100 * v[1] / max(v[0], 1):.1f} %) | "
              f"{100 * v[2] / mob:.0f} % / {100 * v[3] / mob:.0f} % | " + " | ".join(cells) + " |")
    print()


def main(argv):
    if argv and argv[0] == "--split":
        print_split(argv[1:])
        return
    csv_dir = plot_path = None
    brief = False
    dirs = []
    it = iter(argv)
    for a in it:
        if a == "--brief":
            brief = True
        elif a == "--csv":
            csv_dir = next(it)
        elif a == "--plot":
            plot_path = next(it)
        else:
            dirs.append(a)
    if not dirs:
        dirs = sorted(glob.glob(os.path.join(ROOT, "docs", "data", "e2-64", "*")))
    runs = []
    for d in dirs:
        if os.path.exists(os.path.join(d, "summary.json")):
            s = load(d)
            if has_drive(s):
                runs.append((os.path.basename(os.path.normpath(d)), s))
    if not runs:
        sys.exit("no run with the residual-drive replays (drive_r0) among " + ", ".join(dirs))
    drive = [row for name, s in runs for row in drive_rows(name, s)]
    amplitude = [row for name, s in runs for row in amplitude_rows(name, s)]
    for direction in ("compression", "extension"):
        names = [n for n, s in runs if s["loading"]["direction"] == direction]
        if not names:
            continue
        print(f"## {direction}: {', '.join(names)}\n")
        if brief:
            print_brief(direction, [r for r in drive if r["direction"] == direction])
            print_amplitudes(direction, [r for r in amplitude if r["direction"] == direction])
            continue
        for amp in DRIVE_AMPS:
            print_drive(direction, [r for r in drive if r["direction"] == direction], amp)
        print_amplitudes(direction, [r for r in amplitude if r["direction"] == direction])
    if csv_dir:
        os.makedirs(csv_dir, exist_ok=True)
        write_csv(os.path.join(csv_dir, "residual_drive.csv"), drive)
        write_csv(os.path.join(csv_dir, "amplitude_series.csv"), amplitude)
    if plot_path:
        plot(plot_path, drive, amplitude)


if __name__ == "__main__":
    main(sys.argv[1:])
