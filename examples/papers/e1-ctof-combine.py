#!/usr/bin/env python3
# E1 c_tof/pressure series from two runs (docs/validation.md, E1):
#   python3 examples/papers/e1-ctof-combine.py runs/e1-ctof-L25/samples.csv runs/e1-ctof-L25/samples.csv runs/e1-ctof-L8/samples.csv
# (first argument: the run whose moduli give c_ℓ, c_t; then the L ≈ 25 and the L ≈ 8 runs).
# c_ℓ, c_t (from the moduli, per sample) vs p, and c_tof between L ≈ 8 and 25 from per-sample
# leading-edge times: c = (⟨L25⟩ − ⟨L8⟩)/(⟨t25⟩ − ⟨t8⟩); its std over a bootstrap of both sample sets.
import csv, sys, numpy as np
def load(fn):
    rows = [r for r in csv.DictReader(open(fn)) if not r["failure"]]
    out = {}
    for r in rows:
        out.setdefault(float(r["pressure"]), []).append(r)
    return out
def col(rs, k): return np.array([float(r[k]) for r in rs])
tab = load(sys.argv[1])
ps = sorted(tab)
print("moduli speeds (L ≈ 25):")
cl = []; ct = []
for p in ps:
    a, b = col(tab[p], "c_l"), col(tab[p], "c_t"); cl.append(a); ct.append(b)
    print(f"  p {p:g} n {len(a)} c_l {a.mean():.4f} ± {a.std(ddof=1):.4f}  c_t {b.mean():.4f} ± {b.std(ddof=1):.4f}")
lp = np.log(ps)
rng = np.random.default_rng(1)
def slope(series):
    return np.polyfit(lp, np.log([s.mean() for s in series]), 1)[0]
def boot(series, B=2000):
    return np.array([slope([s[rng.integers(0, len(s), len(s))] for s in series]) for _ in range(B)])
for name, s in (("c_l", cl), ("c_t", ct)):
    b = boot(s); print(f"  slope {name}: {slope(s):.4f} (95 % bootstrap {np.percentile(b,2.5):.4f} … {np.percentile(b,97.5):.4f})",
        "effective", [round(float(np.log(s[i+1].mean()/s[i].mean())/np.log(ps[i+1]/ps[i])), 4) for i in range(len(s)-1)])
if len(sys.argv) > 3:
    h25, h8 = load(sys.argv[2]), load(sys.argv[3])
    print("c_tof (10 % leading edge, L ≈ 8 → 25):")
    cs = []; bs = []
    for p in ps:
        if p not in h8 or p not in h25: continue
        L1, t1 = col(h8[p], "height"), col(h8[p], "leading_edge_time")
        L2, t2 = col(h25[p], "height"), col(h25[p], "leading_edge_time")
        c = (L2.mean() - L1.mean()) / (t2.mean() - t1.mean())
        bb = []
        for _ in range(2000):
            i = rng.integers(0, len(L1), len(L1)); j = rng.integers(0, len(L2), len(L2))
            bb.append((L2[j].mean() - L1[i].mean()) / (t2[j].mean() - t1[i].mean()))
        bb = np.array(bb); cs.append(c); bs.append(bb)
        print(f"  p {p:g} n8 {len(L1)} n25 {len(L2)} L8 {L1.mean():.2f} t8 {t1.mean():.2f} ± {t1.std(ddof=1):.2f}  L25 {L2.mean():.2f} t25 {t2.mean():.2f} ± {t2.std(ddof=1):.2f}  c_tof {c:.4f} ± {bb.std():.4f} (bootstrap std)  c_tof/c_l {c/cl[ps.index(p)].mean():.3f}")
    pp = [p for p in ps if p in h8 and p in h25]
    sl = np.polyfit(np.log(pp), np.log(cs), 1)[0]
    bsl = np.array([np.polyfit(np.log(pp), np.log([b[k] for b in bs]), 1)[0] for k in range(2000)])
    print(f"  slope c_tof: {sl:.4f} (95 % bootstrap {np.percentile(bsl,2.5):.4f} … {np.percentile(bsl,97.5):.4f}) vs 1/6 = 0.1667",
        "effective", [round(float(np.log(cs[i+1]/cs[i])/np.log(pp[i+1]/pp[i])), 4) for i in range(len(cs)-1)])
