#!/usr/bin/env python3
# E1 chain reference (docs/validation.md, E1): exponents of the closed-form mode sum on a fine grid.
# Usage: python3 examples/papers/e1-chain-modesum.py 50 100 200 400 800 1600 3200 6400 12800 25600 51200 102400
#        python3 examples/papers/e1-chain-modesum.py check runs/e1-chain/signals/N6400.csv …  (vs grainwave's columns)
#        python3 examples/papers/e1-chain-modesum.py prefactors [--run runs/e1-chain] 50 100 … 102400
#          (a(N) = A N^(2/3), b(N) = W N^(-1/3) from the mode sum, from grainwave's run, and the
#           asymptotic closed form with its first correction; the derivation is in docs/e1.md)
# Closed-form mode sum of the SPEC §5.6 chain (K = m = ℓ = 1, kick u̇₁ = 1, ends tied to walls):
# F(t) = u_N(t) = Σ_k (2/(N+1)) sin(kπ/(N+1)) sin(kπN/(N+1)) sin(ω_k t)/ω_k, ω_k = 2 sin(kπ/(2(N+1))).
# First lobe metrics with the definitions of grainwave-analysis signal.rs (first local max reaching
# 0.1 of the window maximum that falls to half before exceeding itself; parabolic vertex; 10 % edge,
# zero crossing, W = zero − edge), on a fine grid around the front (step N^(1/3)/400).
import numpy as np, sys, csv, math
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
def airy(x, terms=90):
    """Ai(x), Ai'(x) by the Taylor series of y'' = x y about 0 (|x| <= 4: rounding ~1e-13)."""
    a0 = 1 / (3 ** (2/3) * math.gamma(2/3)); a1 = -1 / (3 ** (1/3) * math.gamma(1/3))
    c = [a0, a1, 0.0]
    for n in range(1, terms):
        c.append(c[n-1] / ((n + 2) * (n + 1)))
    ai = sum(ck * x ** k for k, ck in enumerate(c)); dai = sum(k * ck * x ** (k-1) for k, ck in enumerate(c) if k)
    return ai, dai
def root(f, a, b):
    fa = f(a)
    for _ in range(200):
        m = 0.5 * (a + b); fm = f(m)
        if (fm > 0) == (fa > 0): a, fa = m, fm
        else: b = m
    return 0.5 * (a + b)
def asymptotics():
    """First lobe of F = u_N for N -> oo (docs/e1.md, "The chain's first lobe"): with M = N + 1,
    X = 2(M - t)/t^(1/3), u_N = 8 M^(-2/3) [F0(X) + M^(-2/3) F1(X) + O(M^(-4/3))],
    F0 = -Ai'(X), F1 = -[(X/3) Ai'(X) + (7/6) Ai3(X) - (1/60) Ai6(X)] (Ai3, Ai6: third and sixth
    derivatives). Returns a_inf, c_A, b_inf, c_W and the Airy numbers used:
    A N^(2/3) = a_inf (1 + c_A N^(-2/3) - 2/(3N)), W N^(-1/3) = b_inf (1 + c_W N^(-2/3) + 1/(3N)),
    each up to O(N^(-4/3))."""
    Ai = lambda x: airy(x)[0]; dAi = lambda x: airy(x)[1]
    d3 = lambda x: Ai(x) + x * dAi(x)                            # third derivative: Ai + x Ai'
    d6 = lambda x: (4 + x ** 3) * Ai(x) + 6 * x * dAi(x)         # sixth derivative
    F0 = lambda x: -dAi(x); dF0 = lambda x: -x * Ai(x)           # Ai'' = x Ai
    F1 = lambda x: -((x / 3) * dAi(x) + 7/6 * d3(x) - d6(x) / 60)
    peak = F0(0.0)                                               # the lobe's maximum is at X = 0
    xz = root(dAi, -1.5, -0.5)                                   # a'_1: first zero of Ai'
    xe = root(lambda x: F0(x) - 0.1 * peak, 0.5, 4.0)            # 10 % leading edge
    a_inf = 8 * peak; c_A = F1(0.0) / peak
    dz = -F1(xz) / dF0(xz); de = (0.1 * F1(0.0) - F1(xe)) / dF0(xe)
    b_inf = (xe - xz) / 2; c_W = ((de - dz) / 2 + (xz ** 2 - xe ** 2) / 12) / b_inf
    return dict(a_inf=a_inf, c_A=c_A, b_inf=b_inf, c_W=c_W, Ai0=Ai(0.0), dAi0=dAi(0.0), a1p=xz, X_edge=xe)
if sys.argv[1] == "prefactors":
    # Usage: e1-chain-modesum.py prefactors [--run RUN_DIR] N ...  (mode sum at each N; with --run, also
    # grainwave's first-lobe metrics from RUN_DIR/samples.csv, columns grains, peak_amplitude, width)
    args = sys.argv[2:]; run = None
    if args and args[0] == "--run":
        run = args[1]; args = args[2:]
    c = asymptotics()
    print(f"# a_inf = 8/(3^(1/3) Gamma(1/3)) = -8 Ai'(0) = {c['a_inf']:.6f}   c_A = -(11/10) Ai(0)/(-Ai'(0)) = {c['c_A']:.5f}")
    print(f"# b_inf = (X_e - a'_1)/2 = ({c['X_edge']:.6f} + {-c['a1p']:.6f})/2 = {c['b_inf']:.6f}   c_W = {c['c_W']:.5f}")
    print("# A N^(2/3) = a_inf (1 + c_A N^(-2/3) - 2/(3N) + O(N^(-4/3))),  W N^(-1/3) = b_inf (1 + c_W N^(-2/3) + 1/(3N) + O(N^(-4/3)))")
    gw = {}
    if run:
        with open(run + "/samples.csv") as fh:
            for r in csv.DictReader(fh):
                gw[int(r["grains"])] = (float(r["peak_amplitude"]), float(r["width"]))
    Ns = [int(x) for x in args] or sorted(gw)
    print("N,a_modesum,a_grainwave,a_two_term,a_modesum/a_inf-1,b_modesum,b_grainwave,b_two_term,b_modesum/b_inf-1")
    rows = []
    for N in Ns:
        s3 = N ** (1/3)
        t = np.arange(N - 8*s3 - 5, N + 12*s3 + 10, s3/400)
        A, e, W, tp = metrics(t, signal(N, t))
        a = A * N ** (2/3); b = W / s3
        a2 = c["a_inf"] * (1 + c["c_A"] * N ** (-2/3) - 2 / (3 * N)); b2 = c["b_inf"] * (1 + c["c_W"] * N ** (-2/3) + 1 / (3 * N))
        ga, gb = (gw[N][0] * N ** (2/3), gw[N][1] / s3) if N in gw else (float("nan"), float("nan"))
        rows.append((N, a, b))
        print(f"{N},{a:.6f},{ga:.6f},{a2:.6f},{a / c['a_inf'] - 1:.3e},{b:.6f},{gb:.6f},{b2:.6f},{b / c['b_inf'] - 1:.3e}", flush=True)
    # the leading correction measured: (a/a_inf - 1 + 2/(3N)) N^(2/3) -> c_A as N grows (likewise b)
    for N, a, b in rows:
        print(f"# N = {N}: (a/a_inf - 1 + 2/(3N)) N^(2/3) = {(a / c['a_inf'] - 1 + 2 / (3 * N)) * N ** (2/3):.4f} (c_A {c['c_A']:.4f}); "
              f"(b/b_inf - 1 - 1/(3N)) N^(2/3) = {(b / c['b_inf'] - 1 - 1 / (3 * N)) * N ** (2/3):.4f} (c_W {c['c_W']:.4f})")
elif sys.argv[1] == "check":   # against the closed_form column written by grainwave
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
