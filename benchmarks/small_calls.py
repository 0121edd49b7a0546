"""Small calls: what one point costs against the bare formula and against tmm.

Optimisation loops, per-sample renderer callbacks and interactive use evaluate one point at a
time, where a call costs its per-op dispatch and its Python, not its arithmetic. Three yardsticks,
each timed in paired rounds in the same process (the library and its reference alternate; the
figure is the median of the per-round ratios, with the min–max over rounds), one torch thread,
float64:

* **thin film / bare Airy**: ``torchirid.thin_film_reflectance`` at one point (all six arguments
  0-d float64 tensors; or λ and cos θ such tensors and the film, thickness and media Python floats) against the bare torch ops of the same Airy formula written out below
  (``bare_airy``: Snell cosines, s and p Fresnel amplitudes, the film phase, the Airy sum and the
  mean of |r|² — no checks, no guards, on 0-d tensors made beforehand);
* **Bragg mirror / tmm**: ``torchirid.bragg_reflectance`` (Yeh's closed form, N = 20 cells) at
  one point against the pure-Python ``tmm.coh_tmm`` on the same stack of 42 media
  (incident n1 | (n2 d2, n1 d1) × 20 | n1, the library's order): unpolarized against one ``coh_tmm`` call (the
  issue's yardstick), unpolarized against tmm's unpolarized answer (``coh_tmm`` for s and p: the
  same answer), and s against ``coh_tmm('s')``;
* **Bragg colour**: one ``bragg_xyz`` colour (the spectral method, ~7 000 wavelengths), absolute.

Every pair is checked for the same answer first (thin film to 1e-13, Bragg to 1e-12 of tmm).
The op counts are torch operator calls per library call (``TorchDispatchMode``; reading a
value back counts as one).

Run: ``.venv/bin/python benchmarks/small_calls.py`` (~1 min; ``--rounds`` to change the 15
rounds). ``PYTHONPATH=<other checkout>/src`` measures another version of the library.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import numpy as np
import torch

torch.set_num_threads(1)

import tmm  # noqa: E402

import torchirid as ti  # noqa: E402

F = torch.float64
C = torch.complex128


def bare_airy(lam, c, nf, d, ns, n0):
    """R of a film (unpolarized), the minimal op sequence of the Airy formula on 0-d tensors."""
    n02, nf2, ns2 = n0 * n0, nf * nf, ns * ns
    s2 = n02 * (1 - c * c)  # Snell invariant
    q0 = n0 * c
    qf = torch.sqrt((nf2 - s2).to(C))  # n cos θ in the film and the substrate
    qs = torch.sqrt((ns2 - s2).to(C))
    r01s = (q0 - qf) / (q0 + qf)  # s: η = q
    r12s = (qf - qs) / (qf + qs)
    a, b = nf2 * q0, n02 * qf  # p: η = q/n², written without the divisions
    r01p = (a - b) / (a + b)
    a, b = ns2 * qf, nf2 * qs
    r12p = (a - b) / (a + b)
    e2 = torch.exp(qf * (4j * math.pi) * d / lam)  # e^{2iφ}, φ = 2π q_f d / λ
    ts, tp = r12s * e2, r12p * e2
    rs = (r01s + ts) / (1 + r01s * ts)
    rp = (r01p + tp) / (1 + r01p * tp)
    return 0.5 * (rs.abs().square() + rp.abs().square())


class _Count(torch.utils._python_dispatch.TorchDispatchMode):
    def __init__(self):
        super().__init__()
        self.ops = 0

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        self.ops += 1
        return func(*args, **(kwargs or {}))


def ops_per_call(fn) -> int:
    fn()
    with _Count() as count:
        fn()
    return count.ops


def per_call(fn, calls):
    t = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t) / calls


def calls_for(fn, seconds=0.04):
    fn()
    n = 1
    while per_call(fn, n) * n < seconds / 4:
        n *= 2
    return max(4, int(n * seconds / max(per_call(fn, n) * n, 1e-9)))


def paired(lib, ref, rounds):
    """(median ratio, min, max, median lib µs, median ref µs) over paired rounds."""
    n_lib, n_ref = calls_for(lib), calls_for(ref)
    ratios, tl, tr = [], [], []
    for k in range(rounds):
        if k % 2:  # alternate which one goes first
            b = per_call(ref, n_ref)
            a = per_call(lib, n_lib)
        else:
            a = per_call(lib, n_lib)
            b = per_call(ref, n_ref)
        ratios.append(a / b)
        tl.append(a)
        tr.append(b)
    return statistics.median(ratios), min(ratios), max(ratios), statistics.median(tl) * 1e6, statistics.median(tr) * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args()

    print(f"torchirid from {ti.__file__}")
    print(f"torch {torch.__version__}, {torch.get_num_threads()} thread, float64, {args.rounds} paired rounds")
    print()

    # --- thin film against the bare Airy formula
    T = {k: torch.tensor(v, dtype=F) for k, v in
         dict(lam=550.0, c=0.8, nf=1.33, d=300.0, ns=1.5, n0=1.0).items()}
    args_t = (T["lam"], T["c"], T["nf"], T["d"], T["ns"])

    def film_tensors():
        return ti.thin_film_reflectance(*args_t, n_incident=T["n0"])

    def film_floats():  # the structure as Python numbers (λ and cos θ carry the float64)
        return ti.thin_film_reflectance(T["lam"], T["c"], 1.33, 300.0, 1.5, n_incident=1.0)

    def bare():
        return bare_airy(T["lam"], T["c"], T["nf"], T["d"], T["ns"], T["n0"])

    for fn in (film_tensors, film_floats):
        err = abs(float(fn()) - float(bare()))
        assert err < 1e-13, (fn.__name__, err)
    print(f"thin film, one point: R = {float(bare()):.15f} (library − bare: {float(film_tensors()) - float(bare()):.1e})")

    # --- Bragg mirror against tmm on the same stack
    lam_b, c_b = torch.tensor(550.0, dtype=F), torch.tensor(0.8, dtype=F)
    n1, n2, d1, d2, N = 1.0, 1.5, 125.0, 375.0, 20
    stack_n = [n1] + [n2, n1] * N + [n1]
    stack_d = [np.inf] + [d2, d1] * N + [np.inf]
    th0 = math.acos(0.8)

    def bragg():
        return ti.bragg_reflectance(lam_b, c_b, n1, n2, d1, d2, N)

    def bragg_s():
        return ti.bragg_reflectance(lam_b, c_b, n1, n2, d1, d2, N, polarization="s")

    def tmm_s():
        return tmm.coh_tmm("s", stack_n, stack_d, th0, 550.0)["R"]

    def tmm_unpolarized():
        return 0.5 * (tmm.coh_tmm("s", stack_n, stack_d, th0, 550.0)["R"]
                      + tmm.coh_tmm("p", stack_n, stack_d, th0, 550.0)["R"])

    assert len(stack_n) == 42  # media: tmm's list (41 boundaries between them)
    err_u = abs(float(bragg()) - tmm_unpolarized())
    err_s = abs(float(bragg_s()) - tmm_s())
    assert err_u < 1e-12 and err_s < 1e-12, (err_u, err_s)
    print(f"Bragg N = 20, the 42-medium stack: R = {float(bragg()):.15f} (− tmm: {err_u:.1e}; s: {err_s:.1e})")

    one = torch.tensor(0.8, dtype=F)

    def colour():
        return ti.bragg_xyz(one, n1, n2, d1, d2, N)

    print()
    print("| call | ops per call | library (µs) | reference (µs) | ratio, median [min–max] |")
    print("|---|---:|---:|---:|---:|")
    rows = [
        ("thin film, 0-d tensors / bare Airy", film_tensors, bare),
        ("thin film, structure as Python floats / bare Airy", film_floats, bare),
        ("Bragg N = 20, unpolarized / one coh_tmm", bragg, tmm_s),
        ("Bragg N = 20, unpolarized / tmm unpolarized (s + p)", bragg, tmm_unpolarized),
        ("Bragg N = 20, s / coh_tmm s", bragg_s, tmm_s),
    ]
    print(f"| bare Airy formula (reference) | {ops_per_call(bare)} | | | |")
    for name, lib, ref in rows:
        med, lo, hi, tl, tr = paired(lib, ref, args.rounds)
        print(f"| {name} | {ops_per_call(lib)} | {tl:.1f} | {tr:.1f} | {med:.2f}× [{lo:.2f}–{hi:.2f}] |")
        sys.stdout.flush()
    n_col = calls_for(colour, 0.2)
    times = [per_call(colour, n_col) for _ in range(max(3, args.rounds // 3))]
    print(f"| one bragg_xyz colour (spectral) | {ops_per_call(colour)} | {statistics.median(times) * 1e6:.0f} | | |")


if __name__ == "__main__":
    main()
