"""E3: where the contacts opened by the load lie (a run directory of e3-first-opening-mu1-map.toml
or any 15 × 60 full-row slab/sweep run with per-run files).

Usage: python3 e3-opened-contacts.py OUT [F1,F2,...] [picture.png]

Per force (every runs/<case>/F<F>/contact_changes.csv under OUT): the number of opened contacts,
how many lie in the cone between the two lattice directions through the loaded grain
(|Δx| ≤ depth/√3 + 1 R̄, depth measured from the loaded grain's lattice position), how many within
3 R̄ of the loaded grain (the seed distance of the opened region, docs/e3.md), the nearest one's
distance and the shallowest depth in the cone. The picture maps the opened contacts of the listed
forces. The loaded grain is the top-row grain at x = 61 R̄ of the 15 × 60 full-row lattice."""
import csv, glob, math, os, sys
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
root = sys.argv[1]
x0, z0 = 61.0, 1.0 + 14 * math.sqrt(3.0)
runs = {}
for d in glob.glob(f"{root}/runs/*/F*"):
    F = float(os.path.basename(d)[1:])
    rows = list(csv.DictReader(open(f"{d}/contact_changes.csv")))
    runs[F] = rows
summary = []
for F in sorted(runs):
    op = [r for r in runs[F] if r["state"] == "opened"]
    pts = [(float(r["x"]) - x0, z0 - float(r["z"]), r["kind"], float(r["fn_before"])) for r in op]
    cone = [p for p in pts if abs(p[0]) <= p[1] / math.sqrt(3.0) + 1.0]
    near = [p for p in pts if math.hypot(p[0], p[1]) <= 3.0]
    mind = min((math.hypot(p[0], p[1]) for p in pts), default=float("nan"))
    shallow_cone = min((p[1] for p in cone), default=float("nan"))
    print(f"F={F:6.2f} opened={len(op):3d} in-cone={len(cone):3d} within3={len(near)} nearest={mind:6.2f} shallowest-in-cone-depth={shallow_cone:6.2f} "
          f"wall={sum(p[2]=='wall' for p in pts)} depth-range-in-cone=({min((p[1] for p in cone),default=float('nan')):.1f},{max((p[1] for p in cone),default=float('nan')):.1f}) "
          f"fn_before(median in cone)={sorted(p[3] for p in cone)[len(cone)//2] if cone else float('nan'):.3f}")
    summary.append((F, pts))
sel = [s for s in summary if s[0] in (float(a) for a in sys.argv[2].split(","))] if len(sys.argv) > 2 else summary[-4:]
fig, axs = plt.subplots(len(sel), 1, figsize=(10, 2.6 * len(sel)), sharex=True)
for ax, (F, pts) in zip(axs, sel):
    ax.plot([-60.5, 60.5, 60.5, -60.5, -60.5], [z0, z0, z0 + 0.0, z0, z0], lw=0)
    ax.axhline(z0 - 0.0, color="0.8", lw=0.5)
    ax.fill_between([-61, 61], [0, 0], [z0, z0], color="0.95")
    xs = [p[0] for p in pts]; zs = [-p[1] for p in pts]
    ax.scatter(xs, zs, s=10, c=["tab:green" if p[2] == "pair" else "tab:purple" for p in pts])
    for s in (-1, 1):
        ax.plot([0, s * z0 / math.sqrt(3.0)], [0, -z0], color="tab:red", lw=0.6, ls="--")
    ax.plot([0], [0], marker="v", color="k")
    ax.set_ylim(-z0 - 1.5, 1.5); ax.set_xlim(-61, 61); ax.set_aspect("equal")
    ax.set_ylabel("z − z_load [R̄]")
    ax.set_title(f"μ = 1, F_ext = {F:g} m̄g: {len(pts)} opened contacts (green: grain–grain, purple: wall)", fontsize=9)
axs[-1].set_xlabel("x − x_load [R̄]  (dashed: the lattice directions through the loaded grain)")
fig.tight_layout(); fig.savefig(sys.argv[3] if len(sys.argv) > 3 else f"{root}/opened_contacts.png", dpi=110)
