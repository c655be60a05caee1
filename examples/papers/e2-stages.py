#!/usr/bin/env python3
"""Stage by stage wall-clock of an E2 study, read from its run directory (`run.log` and
`config.resolved.toml`):

    python3 examples/papers/e2-stages.py docs/data/e2-128/compression

Stages: the preparation, the loading (the log's own total, which adds the loading time of every
process that worked on it), and the chain of replays after the loading, split into
  * Table 2: the replays the decomposition of SPEC §6.6 needs — the four states of `[static_limit]`
    (undeformed, non-sliding, static, deforming) and everything they are replayed from;
  * the canonical chain: Table 2, the other stops and slow-downs of `[static_limit] variants`
    (Fig. 10/11) and the anisotropy pulses of `[anisotropy]`, with what they are replayed from;
  * the other replays of the config (for instance the residual-drive and amplitude series).
For each the time from the end of the loading to the end of its last replay: replays run two at a
time (or more, with more workers) in the plan's order, so this is the time the study took to have
those results, with the later replays sharing the workers. Times are the log's seconds since the
start of the process that ran the chain; a chain split over several processes (interrupted and
resumed) is reported as such; in a run still going, a replay not finished shows the time of its
last line. Standard library only.
"""
import os
import re
import sys
import tomllib

LINE = re.compile(r"^\[\s*([0-9.]+) s\] (.*)$")


def closure(replays, names):
    """`names` and every replay they are replayed from (`from`)."""
    out, todo = set(), list(names)
    while todo:
        n = todo.pop()
        if n in out or n not in replays:
            continue
        out.add(n)
        src = replays[n].get("from")
        if src:
            todo.append(src)
    return out


def groups(config):
    replays = {r["name"]: r for r in config.get("replays", [])}
    sl = config.get("static_limit", {})
    table2 = closure(replays, [sl.get(k) for k in ("undeformed", "non_sliding", "static_state", "deforming") if sl.get(k)])
    canon = list(table2) + list(sl.get("variants", []))
    an = config.get("anisotropy", {})
    for block in [an] + list(an.get("states", [])):
        canon += [block.get("along_y"), block.get("along_x")]
    canonical = closure(replays, [n for n in canon if n])
    return replays, table2, canonical


def parse(log_path):
    """(segments, info): per process (the log split at "resuming from"), per replay its first and
    last time; and the log's preparation (time, steps), loading total [s] and where the loading
    ended (segment index, time)."""
    segments, info = [{}], {}
    with open(log_path, encoding="utf-8") as f:
        for line in f:
            m = LINE.match(line.rstrip("\n"))
            if not m:
                continue
            t, text = float(m.group(1)), m.group(2)
            if text.startswith("resuming from"):
                segments.append({})
                continue
            pc = re.match(r"preparation converged: (\d+) steps", text)
            if pc:
                info["preparation"] = (t, int(pc.group(1)))
            ld = re.match(r"loading done: .* after ([0-9.]+) t\*, (\d+) checkpoints, ([0-9.]+) s", text)
            if ld:
                info["loading"] = float(ld.group(3))
                info["loading_end"] = (len(segments) - 1, t)
            rp = re.match(r"replay ([A-Za-z0-9_]+)[ :]", text)
            if rp:
                a, _ = segments[-1].get(rp.group(1), (t, t))
                segments[-1][rp.group(1)] = (a, t)
    return segments, info


def fmt(s):
    return f"{s:7.0f} s ({s / 60:5.1f} min)"


def main(path):
    with open(os.path.join(path, "config.resolved.toml"), "rb") as f:
        config = tomllib.load(f)
    replays, table2, canonical = groups(config)
    segments, info = parse(os.path.join(path, "run.log"))
    print(f"# {path}")
    if "preparation" in info:
        t, steps = info["preparation"]
        print(f"preparation          {fmt(t)}  {steps} steps (first process)")
    if "loading" not in info:
        print("loading              not finished")
        return
    print(f"loading              {fmt(info['loading'])}  (the log's total over every process)")
    k, t0 = info["loading_end"]
    seg = segments[k]
    if len(segments) > k + 1:
        print(f"note: the chain was resumed {len(segments) - k - 1} time(s); the times below are of the first process only")
    rows = [("Table 2 replays", table2), ("canonical chain", canonical), ("every replay", set(replays))]
    for label, names in rows:
        ends = [seg[n][1] for n in names if n in seg]
        missing = sorted(n for n in names if n not in seg)
        if missing:
            print(f"{label:20s} not all in this process (missing: {', '.join(missing)})")
            continue
        print(f"{label:20s} {fmt(max(ends) - t0)} after the loading ({len(names)} replays)")
    print("per replay (start, end after the loading; * = outside the canonical chain):")
    for n in replays:
        if n in seg:
            a, b = seg[n]
            print(f"  {n:22s} {a - t0:8.0f} {b - t0:8.0f}{'' if n in canonical else ' *'}")


if __name__ == "__main__":
    for p in sys.argv[1:] or [os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "data", "e2-128", "compression")]:
        main(os.path.normpath(p))
