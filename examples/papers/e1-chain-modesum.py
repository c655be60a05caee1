#!/usr/bin/env python3
# E1 chain reference (docs/validation.md, E1): exponents of the closed-form mode sum on a fine grid.
# Usage: python3 examples/papers/e1-chain-modesum.py 50 100 200 400 800 1600 3200 6400 12800 25600 51200 102400
#        python3 examples/papers/e1-chain-modesum.py check runs/e1-chain/signals/N6400.csv …  (vs grainwave's columns)
# Closed-form mode sum of the SPEC §5.6 chain (K = m = ℓ = 1, kick u̇₁ = 1, ends tied to walls):
# F(t) = u_N(t) = Σ_k (2/(N+1)) sin(kπ/(N+1)) sin(kπN/(N+1)) sin(ω_k t)/ω_k, ω_k = 2 sin(kπ/(2(N+1))).
# First lobe metrics with the definitions of grainwave-analysis signal.rs (first local max reaching
# 0.1 of the window maximum that falls to half before exceeding itself; parabolic vertex; 10 % edge,
# zero crossing, W = zero − edge), on a fine grid around the front (step N^(1/3)/400).
import numpy as np, sys, csv
def signal(N, t):
    k = np.arange(1, N + 1)
    th = k * np.pi / (N + 1)
    w = 2 * np.sin(th / 2)
    shape = 2.0 / (N + 1) * np.sin(th) * np.sin(th * N)
    out = np.empty_like(t)
    for i in range(0, len(t), 256):
        out[i:i+256] = (np.sin(np.outer(t[i:i+256], w)) * (shape / w)).sum(axis=1)
    return out
def interp(t, f, a, b, lev):
    return t[a] + (lev - f[a]) / (f[b] - f[a]) * (t[b] - t[a])
def metrics(t, f):
    mx = f.max(); lev = 0.1 * mx
    for k in range(1, len(f) - 1):
        if f[k] >= lev and f[k] >= f[k-1] and f[k+1] < f[k]:
            ok = True
            for v in f[k+1:]:
                if v > f[k]: ok = False; break
                if v <= 0.5 * f[k]: break
            if ok: break
    t0, t1, t2 = t[k-1:k+2]; f0, f1, f2 = f[k-1:k+2]
    d01 = (f1-f0)/(t1-t0); d12 = (f2-f1)/(t2-t1); c2 = (d12-d01)/(t2-t0); c1 = d01 - c2*(t0+t1)
    tv = -c1/(2*c2); A = f1 + d01*(tv-t1) + c2*(tv-t0)*(tv-t1)
    j = next(j for j in range(1, k+1) if f[j] >= 0.1*A); edge = interp(t, f, j-1, j, 0.1*A)
    z = next(j for j in range(k+1, len(f)) if f[j] <= 0); zero = interp(t, f, z-1, z, 0.0)
    return A, edge, zero - edge, tv
if sys.argv[1] == "check":   # against the closed_form column written by grainwave
    for fn in sys.argv[2:]:
        r = np.genfromtxt(fn, delimiter=",", names=True)
        N = int(round(r["time"][-1] / 1.3))
        s = signal(N, r["time"])
        print(fn, N, "max|diff|/max", np.abs(s - r["closed_form"]).max() / np.abs(r["closed_form"]).max(), "vs generic", np.abs(s - r["s0001"]).max() / np.abs(s).max())
else:
    Ns = [int(x) for x in sys.argv[1:]]
    rows = []
    for N in Ns:
        s3 = N ** (1/3)
        t = np.arange(N - 8*s3 - 5, N + 12*s3 + 10, s3/400)
        A, e, W, tp = metrics(t, signal(N, t))
        rows.append((N, A, W, e, tp)); print(N, A, W, e, tp, flush=True)
    for (n1, a1, w1, *_), (n2, a2, w2, *_) in zip(rows, rows[1:]):
        print(f"eff {n1}-{n2}: gamma {-np.log(a2/a1)/np.log(n2/n1):.4f} alpha {np.log(w2/w1)/np.log(n2/n1):.4f}")
    N = np.array([r[0] for r in rows]); A = np.array([r[1] for r in rows]); W = np.array([r[2] for r in rows])
    print("fit gamma", -np.polyfit(np.log(N), np.log(A), 1)[0], "alpha", np.polyfit(np.log(N), np.log(W), 1)[0])
