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
* **Bragg colour**: one ``bragg_xyz`` colour (the spectral method, ~7 000 wavelengths), absolute;
* **larger calls** (absolute, to compare versions): what the small-call paths must not slow down.

Every pair is checked for the same answer first (thin film to 1e-13, Bragg to 1e-12 of tmm).
The op counts are torch operator calls per library call (``TorchDispatchMode``; reading a
value back counts as one).

Times are this process's CPU time by default (``--clock wall`` for elapsed time): on a shared
machine the slices other processes take do not count, which keeps the rounds comparable.

Run: ``.venv/bin/python benchmarks/small_calls.py`` (~1 min; ``--rounds`` to change the 15
rounds). ``PYTHONPATH=<other checkout>/src`` measures another version of the library;
``--compare <other checkout>/src`` adds the larger calls timed against it in alternating child
processes (paired rounds; ~1 min more).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # one thread for NumPy (tmm) too
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402

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


CLOCK = {"cpu": time.process_time, "wall": time.perf_counter}
clock = CLOCK["cpu"]


def per_call(fn, calls):
    t = clock()
    for _ in range(calls):
        fn()
    return (clock() - t) / calls


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
    parser.add_argument("--clock", choices=tuple(CLOCK), default="cpu",
                        help="cpu: this process's CPU time (default: on a shared machine the time slices other "
                             "processes take do not count); wall: elapsed time")
    parser.add_argument("--compare", metavar="SRC",
                        help="also time the larger calls against the library under SRC (e.g. an older commit's "
                             "src/ from git archive), in alternating child processes")
    parser.add_argument("--larger-json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    global clock
    clock = CLOCK[args.clock]
    if args.larger_json:
        _larger_json()
        return

    print(f"torchirid from {ti.__file__}")
    print(f"torch {torch.__version__}, {torch.get_num_threads()} thread, float64, {args.rounds} paired rounds, "
          f"{args.clock} clock")
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
    print(f"| one bragg_xyz colour (spectral), absolute below | {ops_per_call(colour)} | | | |")
    print()
    print("| larger call | library (µs), median [min–max] |")
    print("|---|---:|")
    for name, fn in larger_calls().items():
        n = calls_for(fn, 0.1)
        times = [per_call(fn, n) * 1e6 for _ in range(max(5, args.rounds // 2))]
        print(f"| {name} | {statistics.median(times):.0f} [{min(times):.0f}–{max(times):.0f}] |")
        sys.stdout.flush()
    if args.compare:
        compare(args.compare, args.rounds)


def larger_calls():
    """Larger calls, absolute: what the small-call paths must not slow down."""
    lam = torch.linspace(380.0, 780.0, 401, dtype=F)
    c90 = torch.cos(torch.linspace(0.0, 1.5, 90, dtype=F))[:, None]
    lam81 = torch.linspace(400.0, 720.0, 81, dtype=F)
    d64 = torch.linspace(200.0, 400.0, 64, dtype=F)[:, None]
    one = torch.tensor(0.8, dtype=F)
    return {
        "one bragg_xyz colour (spectral)": lambda: ti.bragg_xyz(one, 1.0, 1.5, 125.0, 375.0, 20),
        "Bragg, 401 wavelengths": lambda: ti.bragg_reflectance(lam, one, 1.0, 1.5, 125.0, 375.0, 20),
        "Bragg, 401 × 90 grid": lambda: ti.bragg_reflectance(lam, c90, 1.0, 1.5, 125.0, 375.0, 20),
        "thin film, 81 wavelengths × 64 thicknesses": lambda: ti.thin_film_reflectance(lam81, 0.9, 1.38, d64, 1.5),
        "thin film, 401 × 90 grid": lambda: ti.thin_film_reflectance(lam, c90, 1.33, 300.0, 1.5),
    }


def _larger_json():
    """(child process) the fastest of a few timings of each larger call, as JSON on stdout"""
    import json

    out = {}
    for name, fn in larger_calls().items():
        n = calls_for(fn, 0.05)
        out[name] = min(per_call(fn, n) for _ in range(5)) * 1e6
    print(json.dumps(out))


def compare(other_src, rounds):
    """Larger calls, this library against the one under ``other_src``: child processes alternating
    in paired rounds (each the fastest of 5 timings per call), median ratio this / other."""
    import json
    import subprocess

    def run(src):
        env = dict(os.environ)
        env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        cmd = [sys.executable, __file__, "--larger-json", "--clock", "cpu" if clock is time.process_time else "wall"]
        return json.loads(subprocess.run(cmd, env=env, check=True, capture_output=True, text=True).stdout)

    here = os.path.dirname(os.path.dirname(ti.__file__))
    ratios, times = {}, {}
    for k in range(max(3, rounds // 3)):
        pair = (run(other_src), run(here)) if k % 2 == 0 else tuple(reversed((run(here), run(other_src))))
        for name in pair[0]:
            ratios.setdefault(name, []).append(pair[1][name] / pair[0][name])
            times.setdefault(name, []).append((pair[0][name], pair[1][name]))
    print()
    print(f"Larger calls against {other_src}: child processes in {len(next(iter(ratios.values())))} paired rounds, "
          "the fastest of 5 timings per call")
    print()
    print("| larger call | other (µs) | this (µs) | this / other, median [min–max] |")
    print("|---|---:|---:|---:|")
    for name, r in ratios.items():
        other = statistics.median(t[0] for t in times[name])
        this = statistics.median(t[1] for t in times[name])
        print(f"| {name} | {other:.0f} | {this:.0f} | {statistics.median(r):.2f} [{min(r):.2f}–{max(r):.2f}] |")


if __name__ == "__main__":
    main()
