"""``torchirid.multilayer`` against ``tmm_fast.coh_tmm`` on 401 λ × 90 θ, L = 2 / 10 / 40 / 200 films.

Grid: λ = 380–780 nm (401), θ = 0–89° (90): 36 090 points, float64, unpolarized (both s and p;
tmm_fast takes one polarization per call, so it is called twice). Stack of L films: air |
random dielectrics n ∈ [1.3, 2.4] (every third film weakly absorbing, κ ≤ 0.05), d ∈ [20, 300]
nm | glass 1.52, the same for both codes (tmm_fast gets the indices repeated over λ, as its
API requires; torchirid broadcasts them).

Paired rounds: each round times tmm_fast and torchirid back to back for every L (the faster
code as the median of several calls), the speed-up of a round is tmm_fast's time over ours,
and the table reports the median over rounds [min–max], so that the load of other processes
on the shared machine cancels instead of favouring one side. Accuracy: max |R − R_tmm| and
|T − T_tmm| against ``tmm.coh_tmm`` (one point per call) on a random subsample of the grid.

    .venv/bin/python benchmarks/multilayer_vs_tmm_fast.py                 # 7 rounds, 2 threads (~5 min)
    .venv/bin/python benchmarks/multilayer_vs_tmm_fast.py --rounds 11 --layers 2 10 40 200
    .venv/bin/python benchmarks/multilayer_vs_tmm_fast.py --stack bragg   # a Bragg mirror: 2 distinct films
    .venv/bin/python benchmarks/multilayer_vs_tmm_fast.py --memory 10000000 --rounds 1 --layers 2
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch

import torchirid as ti


def grid(dtype=torch.float64):
    lam = torch.linspace(380.0, 780.0, 401, dtype=dtype)
    theta = torch.deg2rad(torch.linspace(0.0, 89.0, 90, dtype=torch.float64))
    return lam, torch.cos(theta).to(dtype)[:, None], theta


def stack(L: int, kind: str = "random", seed: int = 0):
    """Indices (L + 2,) complex and thicknesses (L,) nm of the benchmark stack: ``random`` (every
    film different) or ``bragg`` (Fourneau et al. 2024 Fig. 1's mirror, air | (1.5 @ 375 nm,
    1 @ 125 nm) × L/2 | air, as benchmarks/speed_vs_error.py: two distinct films)."""
    if kind == "bragg":
        cells = L // 2
        return np.array([1.0] + [1.5, 1.0] * cells + [1.0], dtype=complex), np.array([375.0, 125.0] * cells)
    g = np.random.default_rng(seed + L)
    films = g.uniform(1.3, 2.4, L) + 0j
    films[::3] += 1j * g.uniform(0.0, 0.05, len(films[::3]))
    idx = np.concatenate([[1.0 + 0j], films, [1.52 + 0j]])
    return idx, g.uniform(20.0, 300.0, L)


def peak_memory(points: int, L: int, kind: str) -> tuple[float, float]:
    """Peak resident memory added by one float64 ``multilayer`` call on ``points`` points (λ × θ
    grid) and its output size (R and T), in MB. Run before anything else: ru_maxrss is a high-water
    mark."""
    import resource

    W = 401
    lam = torch.linspace(380.0, 780.0, W, dtype=torch.float64)
    cos = torch.linspace(0.0, 1.0, max(points // W, 1), dtype=torch.float64)[:, None]
    idx, d = stack(L, kind)
    idx_t, d_t = torch.tensor(idx), torch.tensor(d)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    R, T = ti.multilayer(lam, cos, idx_t, d_t)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return (peak - base) / 1024, (R.numel() + T.numel()) * 8 / 2**20


def timed(fn, repeats: int) -> float:
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=7, help="paired rounds (median of the per-round ratios)")
    ap.add_argument("--layers", type=int, nargs="+", default=[2, 10, 40, 200], help="film counts L")
    ap.add_argument("--threads", type=int, default=2, help="torch threads (both codes)")
    ap.add_argument("--repeats", type=int, default=5, help="torchirid calls per round (median)")
    ap.add_argument("--subsample", type=int, default=200, help="grid points checked against tmm.coh_tmm")
    ap.add_argument("--polarization", default="unpolarized", choices=["s", "p", "unpolarized"])
    ap.add_argument("--stack", default="random", choices=["random", "bragg"],
                    help="every film different (default) or a Bragg mirror (two distinct films)")
    ap.add_argument("--memory", type=int, metavar="POINTS", default=0,
                    help="first measure the peak memory of one call on POINTS points (e.g. 10000000), L = 10")
    args = ap.parse_args(argv)
    if args.memory:
        added, out = peak_memory(args.memory, 10, args.stack)
        print(f"peak memory of one call, {args.memory} points, L = 10: +{added:.0f} MB "
              f"= {added / out:.1f}× its output (R and T, {out:.0f} MB)\n", flush=True)

    import tmm
    import tmm_fast

    torch.set_num_threads(args.threads)
    lam, cos, theta = grid()
    pol = args.polarization
    pols = ("s", "p") if pol == "unpolarized" else (pol,)
    rng = np.random.default_rng(1)
    ia = rng.integers(0, cos.numel(), args.subsample)
    iw = rng.integers(0, lam.numel(), args.subsample)

    cases = {}
    for L in args.layers:
        idx, d = stack(L, args.stack)
        idx_t, d_t = torch.tensor(idx), torch.tensor(d)
        M = idx_t[None, :, None].expand(1, L + 2, lam.numel()).contiguous()
        Tm = torch.tensor([np.inf, *(d * 1e-9), np.inf], dtype=torch.float64)[None]
        lam_m = lam * 1e-9

        def peer(M=M, Tm=Tm, lam_m=lam_m):
            out = [tmm_fast.coh_tmm(p, M, Tm, theta, lam_m, device="cpu") for p in pols]
            return sum(o["R"][0] for o in out) / len(out), sum(o["T"][0] for o in out) / len(out)

        def ours(idx_t=idx_t, d_t=d_t):
            return ti.multilayer(lam, cos, idx_t, d_t, polarization=pol)

        R, T = ours()
        Rf, _ = peer()
        dl = [np.inf, *d, np.inf]
        ref = np.array([[np.mean([tmm.coh_tmm(p, list(idx), dl, float(theta[a]), float(lam[w]))[k] for p in pols])
                         for k in ("R", "T")] for a, w in zip(ia, iw)])
        errR = float(np.abs(R.numpy()[ia, iw] - ref[:, 0]).max())
        errT = float(np.abs(T.numpy()[ia, iw] - ref[:, 1]).max())
        errF = float((R - Rf).abs().max())
        cases[L] = dict(peer=peer, ours=ours, errR=errR, errT=errT, errF=errF, tp=[], to=[], ratio=[])

    for r in range(args.rounds):
        for L, c in cases.items():
            tp = timed(c["peer"], 1)
            to = timed(c["ours"], args.repeats)
            c["tp"].append(tp)
            c["to"].append(to)
            c["ratio"].append(tp / to)
        print(f"round {r + 1}/{args.rounds}: " + ", ".join(f"L={L} {c['ratio'][-1]:.1f}×" for L, c in cases.items()),
              flush=True)

    npts = lam.numel() * cos.numel()
    print(f"\n401 λ × 90 θ = {npts} points, float64, {pol}, {args.stack} stack, {args.threads} threads, "
          f"torch {torch.__version__}, {args.rounds} paired rounds\n")
    print("| L | tmm_fast (ms) | multilayer (ms) | ns / point | speed-up vs tmm_fast, median [min–max] "
          "| max \\|R − R_tmm\\| | max \\|T − T_tmm\\| | max \\|R − R_tmm_fast\\| |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for L, c in cases.items():
        tp, to, ra = statistics.median(c["tp"]), statistics.median(c["to"]), c["ratio"]
        print(f"| {L} | {tp * 1e3:.1f} | {to * 1e3:.2f} | {to / npts * 1e9:.0f} | {statistics.median(ra):.1f}× "
              f"[{min(ra):.1f}–{max(ra):.1f}] | {c['errR']:.1e} | {c['errT']:.1e} | {c['errF']:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
