#!/usr/bin/env python3
"""E2 Table 2 (the decomposition of the pulse-speed loss, SPEC §6.6) per packing and over packings,
by both arrival definitions, from the committed summaries of the 64 × 64 runs.

    python3 examples/papers/e2-table2.py                      # the canonical packings in docs/data/e2-64
    python3 examples/papers/e2-table2.py DIR [DIR ...]        # any run directories (summary.json,
                                                              #   or run.log while the study runs)
    python3 examples/papers/e2-table2.py --amplitude 1e-10    # another |p_a| [t*] (default 1e-9)

Arrival definitions (SPEC §6.5): "maximum" = the time of the maximum of |δv_x| (SPEC's headline
definition), "first lobe" = the first lobe of the front (the replays' own, docs/e2.md). Losses
Δc/c₀ are written positive (the published table writes them negative). Means ± standard error
(SD/√n) over the packings, and the sample SD. Standard library only.
"""
import json
import math
import os
import re
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def _canonical(direction):
    """The canonical packings of a direction in docs/data/e2-64: `<direction>` (seed 1) and
    `<direction>-seedN` (the same config with `seed = N`), not the variants (`-no-gravity`, …)."""
    base = os.path.join(ROOT, "docs", "data", "e2-64")
    names = [direction] if os.path.isdir(os.path.join(base, direction)) else []
    seeds = []
    for d in os.listdir(base) if os.path.isdir(base) else []:
        rest = d[len(direction) + len("-seed"):]
        if d.startswith(direction + "-seed") and rest.isdigit() and os.path.exists(os.path.join(base, d, "summary.json")):
            seeds.append((int(rest), d))
    return names + [d for _, d in sorted(seeds)]


CANONICAL = {direction: _canonical(direction) for direction in ("compression", "extension")}
PUBLISHED = {  # (p_a > 0, p_a < 0), magnitudes
    "compression": {"contact_loss": (0.236, 0.233), "sliding": (0.179, 0.260),
                    "strain_rate": (0.115, 0.034), "total": (0.530, 0.527)},
    "extension": {"contact_loss": (0.037, 0.038), "sliding": (0.107, 0.090),
                  "strain_rate": (0.014, 0.032), "total": (0.158, 0.160)},
}
PROCESSES = ["contact_loss", "sliding", "strain_rate", "total"]
KEYS = {"maximum": "speed_maximum", "first lobe": "speed_first_lobe"}


def front(c):
    """A fitted pulse speed, or None when there is no front: the strip fit of arrival time against
    distance has no positive slope. This happens by the maximum of |δv_x| in a deforming state
    whose pulsed and unpulsed replays drift apart by far more than the pulse (the maximum then sits
    at the end of the record, not at the front); the engine reports no speed for such a fit, and
    older summaries that carry the negative slope are read the same way."""
    return c if c is not None and c > 0 else None


def speeds(summary, key):
    out = {}
    for r in summary["replays"]:
        if r["name"] in ("undeformed", "nonsliding", "static", "deforming"):
            for p in r["pairs"]:
                out[(r["name"], p["amplitude"])] = front(p.get(key))
    return out


def losses(sp, amp):
    """The decomposition of Δc/c₀; a process whose speeds include a missing front is None."""
    c0 = sp[("undeformed", amp)]
    cns, cs, cd = sp[("nonsliding", amp)], sp[("static", amp)], sp[("deforming", amp)]
    d = lambda a, b: None if a is None or b is None or c0 is None else (a - b) / c0
    return {"contact_loss": d(c0, cns), "sliding": d(cns, cs), "strain_rate": d(cs, cd), "total": d(c0, cd)}


def stats(xs):
    """(mean, SE, SD, n) over the values that are not None."""
    xs = [x for x in xs if x is not None]
    n = len(xs)
    if n == 0:
        return float("nan"), float("nan"), float("nan"), 0
    m = sum(xs) / n
    s = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1)) if n > 1 else float("nan")
    return m, s / math.sqrt(n), s, n


def cell(x):
    return "no front" if x is None else f"{x:.3f}"


def table(title, runs, amp, published):
    print(f"### {title}: Δc/c₀ at |p_a| = {amp:g} t*, p_a > 0 / p_a < 0\n")
    print("| packing | arrival | contact loss | sliding | strain rate | total |")
    print("|---|---|---|---|---|---|")
    per = {k: {p: ([], []) for p in PROCESSES} for k in KEYS}
    for name, s in runs:
        for label, key in KEYS.items():
            sp = speeds(s, key)
            lp, lm = losses(sp, amp), losses(sp, -amp)
            cells = []
            for p in PROCESSES:
                per[label][p][0].append(lp[p])
                per[label][p][1].append(lm[p])
                cells.append(f"{cell(lp[p])} / {cell(lm[p])}")
            print(f"| {name if label == 'maximum' else ''} | {label} | " + " | ".join(cells) + " |")
    n = len(runs)
    for label in KEYS if n > 1 else []:  # one packing: no mean row (its SE and SD are undefined)
        cells = []
        for p in PROCESSES:
            (mp, ep, sp_, np_), (mm, em, sm, nm) = stats(per[label][p][0]), stats(per[label][p][1])
            fewer = f" [{np_} / {nm} with a front]" if (np_, nm) != (n, n) else ""
            cells.append(f"{mp:.3f} ± {ep:.3f} / {mm:.3f} ± {em:.3f} (SD {sp_:.3f} / {sm:.3f}){fewer}")
        print(f"| **mean ± SE ({n})** | {label} | " + " | ".join(cells) + " |")
    if published:
        print("| published (128², one packing) | maximum | " + " | ".join(
            f"{published[p][0]:.3f} / {published[p][1]:.3f}" for p in PROCESSES) + " |")
    print()


LOG_LINE = re.compile(r"replay (\S+) a = (\S+): speed \S+ v_a \(maximum (\S+), first lobe ([^)]+)\)")


def from_log(path):
    """The speeds of a study that has not finished (no `summary.json` yet) from its `run.log`:
    each replayed pulse's line `replay NAME a = P: speed … (maximum M, first lobe F)` gives the
    same two speeds the summary holds (`—`: no front)."""
    value = lambda x: None if x == "—" else float(x)
    replays = {}
    with open(path) as f:
        for line in f:
            m = LOG_LINE.search(line)
            if m:
                name, a, mx, fl = m.groups()
                replays.setdefault(name, []).append({"amplitude": float(a), "speed_maximum": value(mx), "speed_first_lobe": value(fl)})
    return {"replays": [{"name": n, "pairs": p} for n, p in replays.items()]}


def load(d):
    """A run directory's speeds: its `summary.json`, or, while the study runs, its `run.log`."""
    path = os.path.join(d, "summary.json")
    if not os.path.exists(path) and os.path.exists(os.path.join(d, "run.log")):
        return from_log(os.path.join(d, "run.log"))
    with open(path) as f:
        return json.load(f)


def main(argv):
    amp = 1e-9
    if "--amplitude" in argv:
        i = argv.index("--amplitude")
        amp = abs(float(argv[i + 1]))
        del argv[i:i + 2]
    if argv:
        runs = [(os.path.basename(os.path.normpath(d)), load(d)) for d in argv]
        table("runs", runs, amp, None)
        return 0
    for direction, names in CANONICAL.items():
        runs = [(n, load(os.path.join(ROOT, "docs", "data", "e2-64", n))) for n in names]
        table(f"{direction}, 64 × 64, {len(runs)} packings", runs, amp, PUBLISHED[direction])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
