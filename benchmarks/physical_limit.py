"""How far each kernel is from the arithmetic limit of this CPU (issue 23.5).

The limit of a kernel is the time of its *minimal* arithmetic per point on this CPU, as if the
whole formula were one fused, vectorised loop with every value in registers (no memory traffic,
no temporaries): the count of each primitive in the formula (written out below, per point, both
polarizations, the cheapest known evaluation) times that primitive's measured cost.

Primitive costs (float64, one thread): the transcendentals, ``sqrt`` and division from torch's
vectorised (SLEEF) loops on an L2-resident array of 32 768 elements, where loads and stores are
nearly free beside them; one fused multiply-add from ``torch.compile``'d Horner polynomials
(four independent chains in one loop, the state in registers; two degrees, so that the call
overhead cancels). The limit with ``T`` threads is the
one-thread limit over ``T`` (the ops are independent per point).

Kernels (the throughput benchmark's, 36 090 and 10⁶ points, 2 threads, default evaluation):
``bragg_reflectance`` N = 20 lossless (Yeh's closed form), ``thin_film_reflectance`` (Airy), and
one film of ``multilayer``'s recursion (the L = 40 minus the L = 10 time over 30 films, every film
distinct; the interfaces and admittances depend on the angle only and are amortised over the
wavelengths).

The limit is that of torch's own vectorised primitives (SLEEF, ≤ 1 ulp); a hand-written loop
with cheaper, less accurate approximations of sin/cos/acos could go lower. The operation
counts are the cheapest evaluation known to us, not a proven minimum, per point of a general
batch (on a λ × θ grid the square roots depend on the angle only: the limit is conservative).

Run: ``.venv/bin/python benchmarks/physical_limit.py`` (~1 min; quiet machine).
"""

from __future__ import annotations

import argparse
import time

import torch

import torchirid as ti

F = torch.float64

#: minimal primitive counts per point (both polarizations, unpolarized mean)
COUNTS = {
    # q1, q2 (2 sqrt); sin/cos of a and b (shared by s and p); per polarization: cos KΛ (≈ 8
    # FMA), K = acos, sin K = sqrt(1 − x²), sin NK, U = sin NK / sin K, |C|²U² (≈ 8 FMA),
    # R = |C|²U² / (|C|²U² + 1) (1 div) and the mean
    "bragg (Yeh, N = 20)": {"sqrt": 4, "sin": 4, "cos": 2, "acos": 2, "div": 4, "fma": 40},
    # q1, q2 (2 sqrt); per polarization r01, r12 (2 div), |r01 + r12 e|², |1 + r01 r12 e|² (≈ 12
    # FMA), 1 div; the phase's sin/cos shared
    "thin film (Airy)": {"sqrt": 2, "sin": 1, "cos": 1, "div": 6, "fma": 40},
    # per film and point: sin, cos of φ (shared), e₂ = e₁² (3 FMA), per polarization three
    # complex multiply-adds (x = e₂N, N' = x + rD, D' = D + r x: 4 FMA each)
    "multilayer, per film": {"sin": 1, "cos": 1, "fma": 27},
}


def _per_element(fn, x, out, repeats=300):
    for _ in range(50):
        fn(x, out)
    best = float("inf")
    for _ in range(5):
        t = time.perf_counter()
        for _ in range(repeats):
            fn(x, out)
        best = min(best, (time.perf_counter() - t) / repeats)
    return best / x.numel() * 1e9


def primitive_costs(size: int = 32768) -> dict:
    """ns per element, one thread, float64, L2-resident (32 768 elements: the call overhead
    of ~2 µs is 0.06 ns per element)."""
    g = torch.Generator().manual_seed(0)
    x = torch.rand(size, generator=g, dtype=F) * 0.9 + 0.05
    y = torch.empty_like(x)
    costs = {
        "sqrt": _per_element(lambda a, o: torch.sqrt(a, out=o), x, y),
        "sin": _per_element(lambda a, o: torch.sin(a, out=o), x, y),
        "cos": _per_element(lambda a, o: torch.cos(a, out=o), x, y),
        "acos": _per_element(lambda a, o: torch.acos(a, out=o), x, y),
        "exp": _per_element(lambda a, o: torch.exp(a, out=o), x, y),
        "div": _per_element(lambda a, o: torch.div(a, a, out=o), x, y),
        "mul (torch loop, loads/stores)": _per_element(lambda a, o: torch.mul(a, a, out=o), x, y),
    }
    costs["fma"] = _fma_cost(size)
    return costs


def _fma_cost(size: int, degrees=(8, 72)) -> float:
    """ns per FMA from compiled Horner polynomials (registers only): the time difference of two
    degrees over the difference in FMAs, so that the call overhead cancels; NaN if compile fails."""
    def horner(degree):
        def f(x):  # four independent chains: the FMA throughput, not its latency
            accs = [x * 0 + (1.0 + j) for j in range(4)]
            for k in range(degree):
                accs = [acc * x + (0.5 + 1e-3 * k + 0.1 * j) for j, acc in enumerate(accs)]
            return accs[0] + accs[1] + accs[2] + accs[3]
        return f

    try:
        x = torch.rand(size, dtype=F)
        times = []
        for degree in degrees:
            f = torch.compile(horner(degree), fullgraph=True)
            f(x)
            reps = 200
            best = float("inf")
            for _ in range(5):
                t = time.perf_counter()
                for _ in range(reps):
                    f(x)
                best = min(best, (time.perf_counter() - t) / reps)
            times.append(best)
        return (times[1] - times[0]) / size / (4 * (degrees[1] - degrees[0])) * 1e9
    except Exception:  # pragma: no cover (no C++ compiler)
        return float("nan")


def measured(threads: int, points: int) -> dict:
    W = min(2001, max(2, points // 90))
    A = max(1, points // W)
    lam = torch.linspace(380.0, 780.0, W, dtype=F)
    c = torch.cos(torch.linspace(0.0, 1.5, A, dtype=F))[:, None]
    n = W * A

    def stack(L):  # every film distinct (no film's phase factor is shared with another)
        idx = torch.tensor([1.0] + [1.38, 2.3] * (L // 2) + [1.52], dtype=torch.complex128)
        return idx, 60.0 + 3.7 * torch.arange(L, dtype=F)

    s10, s40 = stack(10), stack(40)
    calls = {
        "bragg (Yeh, N = 20)": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
        "thin film (Airy)": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
        "multilayer L=10": lambda: ti.multilayer(lam, c, *s10),
        "multilayer L=40": lambda: ti.multilayer(lam, c, *s40),
    }
    torch.set_num_threads(threads)

    def ns_per_point(f):  # best of 5 calls after a warm-up
        with torch.no_grad():
            f()
            ts = []
            for _ in range(5):
                t = time.perf_counter()
                f()
                ts.append(time.perf_counter() - t)
        return min(ts) / n * 1e9

    out = {name: ns_per_point(f) for name, f in calls.items()}
    out["multilayer, per film"] = (out.pop("multilayer L=40") - out.pop("multilayer L=10")) / 30
    ti.options(compile=True)  # the compiled closed form: how close a fused loop gets
    try:
        out["bragg (Yeh, N = 20), compiled"] = ns_per_point(calls["bragg (Yeh, N = 20)"])
    finally:
        ti.options(compile=False)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    costs = primitive_costs()
    print("| primitive (float64, 1 thread, L2-resident) | ns / element |")
    print("|---|---:|")
    for k, v in costs.items():
        print(f"| {k} | {v:.3f} |")
    print()
    rows = {size: measured(args.threads, size) for size in (36_090, 1_000_000)}
    print(f"| kernel | minimal ops per point | limit, {args.threads} threads (ns/point) | measured at 36k | "
          f"× limit | measured at 10⁶ | × limit |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name in rows[36_090]:
        count = COUNTS[name.replace(", compiled", "")]
        limit = sum(costs[p] * k for p, k in count.items()) / args.threads
        ops = ", ".join(f"{k} {p}" for p, k in count.items())
        a, b = rows[36_090][name], rows[1_000_000][name]
        print(f"| {name} | {ops} | {limit:.2f} | {a:.1f} | {a / limit:.1f}× | {b:.1f} | {b / limit:.1f}× |")


if __name__ == "__main__":
    main()
