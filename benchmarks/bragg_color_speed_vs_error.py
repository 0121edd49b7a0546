"""Speed against error of the Bragg-mirror colour methods on Fourneau et al. 2024's Fig. 4 grid.

Grids (one call per method and period Λ: the 9 d1/Λ values × 90 angles are one broadcast
batch of 810 colours, so per-call overhead does not dominate the sampled/spectral methods):

* ``fig4`` — Fourneau Fig. 4: n1 = 1, n2 = 1.5, N = 20 cells, Λ ∈ {244, 500, 988} nm,
  d1/Λ ∈ {0.1, …, 0.9}, d2 = Λ − d1, θ = 0, 1, …, 89° (cos θ), unpolarized, D65 / CIE 1931 2°,
  380–780 nm, float64.
* ``dense`` — a harder set with more fringes: the same but n2 = 2.0 and N = 50 cells.

Methods timed and compared with the converged spectral integration (ΔE2000 of CIE Lab
under D65; the error reference is ``method="spectral"`` at its default sampling, 192 ω
samples per fringe, itself checked against 2×, 384):

* ``sampled`` with K ∈ {16, 32, …, 2048} wavelengths uniform in λ;
* ``piecewise`` with s ∈ {1 ("app."), 2, 3, 4, 5, 8, 12, 16} and weights="paper" (the published
  weights w̃·R^e, with correction="paper" and "fitted") and weights="averaged" (the default);
* ``spectral`` with its defaults (the speed-up baseline; its error is against the 2× refinement).

Timing: ``torch.set_num_threads(2)`` (``--threads``; ``--cpus`` pins the process to those
CPUs); the methods of one (grid, Λ) are timed in interleaved rounds (random order per round, every method once per round, fast methods averaged over
several calls per round); time per colour = median over rounds / 810; speed-up = median
over rounds of the per-round ratio to default ``spectral`` (drift of a shared machine
cancels). Per-grid ("all") times are the sums over the three Λ / 2430; errors pool the 2430
colours. Before each round the script waits (bounded by ``--max-wait``) until other processes
leave the cores idle. By default it runs with glibc's mmap/trim thresholds raised to 2^30
(``--malloc tuned``, for every method alike; ``--malloc default`` leaves glibc alone). A
batch-size check times the methods that decide the verdict at 810, 2430 and 8100 colours per call
(fig4, each Λ).
Takes ~4 min at the default 7 rounds, ~9 min with ``--rounds 15``, on 2 idle cores.

Outputs (unless ``--no-write``):

* ``docs/figures/bragg_color_speed_vs_error.png`` — p95 (filled) and median (open) ΔE2000
  against µs per colour, log–log, one panel per (grid, Λ);
* the section between ``<!-- bragg-color:start -->`` and ``<!-- bragg-color:end -->`` of
  ``benchmarks/results/bragg_color.md`` (appended if absent; the rest of the file is kept;
  docs/performance.md is maintained by hand from it).

The package table ``src/torchirid/data/bragg_color_errors.json`` (these errors and times, for
``method="auto"``; its schema is in the builder's docstring) is built from this measurement by
``luts/build_bragg_color_errors.py``; ``--report`` there also writes the two outputs above
from the same run.

    python benchmarks/bragg_color_speed_vs_error.py              # writes the two outputs
    python benchmarks/bragg_color_speed_vs_error.py --no-write   # print the tables only
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import random
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

import torchirid as ti
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.spectral.sampling import spectral_samples

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "docs" / "figures" / "bragg_color_speed_vs_error.png"
PERF_MD = ROOT / "benchmarks" / "results" / "bragg_color.md"
START, END = "<!-- bragg-color:start -->", "<!-- bragg-color:end -->"
MALLOC = str(1 << 30)  # glibc MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_ of --malloc tuned
REF_SPF, CHECK_SPF = 192.0, 384.0  # samples per fringe: error reference (= the default) and its check

GRIDS = {
    "fig4": dict(n1=1.0, n2=1.5, cells=20, periods=(244.0, 500.0, 988.0)),
    "dense": dict(n1=1.0, n2=2.0, cells=50, periods=(244.0, 500.0, 988.0)),
}
FRACTIONS = [round(0.1 * i, 1) for i in range(1, 10)]
ANGLES = list(range(90))
SAMPLES = (16, 32, 64, 128, 256, 512, 1024, 2048)
SUBDIVISIONS = (1, 2, 3, 4, 5, 8, 12, 16)
ENVELOPE_SAMPLES = (16, 24, 32, 48, 64, 96, 128)
FAST = ("piecewise", "envelope")  # the approximations whose place on the front is the question
WEIGHTINGS = (("paper", "paper"), ("paper", "fitted"), ("averaged", "fitted"))
# Fourneau et al. 2024, Table 1 (speed-ups over their reference): app., sub. s = 2, 3, 4, 5
PAPER_TABLE1 = {244: (10.6, 8.8, 5.5, 4.5, 3.8), 500: (6.8, 5.0, 3.5, 2.6, 2.1), 988: (4.2, 3.8, 3.1, 2.4, 1.7)}


def configs():
    out = [{"method": "spectral"}]
    out += [{"method": "sampled", "samples": k} for k in SAMPLES]
    for w, c in WEIGHTINGS:
        out += [{"method": "piecewise", "subdivisions": s, "weights": w, "correction": c} for s in SUBDIVISIONS]
    out += [{"method": "envelope", "samples": k} for k in ENVELOPE_SAMPLES]
    return out


def family(cfg):
    if cfg["method"] != "piecewise":
        return cfg["method"]
    return "piecewise averaged" if cfg["weights"] == "averaged" else f"piecewise paper/{cfg['correction']}"


def label(cfg):
    if cfg["method"] == "spectral":
        return "spectral (default)"
    if cfg["method"] in ("sampled", "envelope"):
        return f"{cfg['method']} K={cfg['samples']}"
    s = cfg["subdivisions"]
    name = "app." if s == 1 else f"sub. s={s}"
    if cfg["weights"] == "averaged":
        return f"piecewise {name} averaged"
    return f"piecewise {name} paper/{cfg['correction']}"


def colours():
    """Colours per call of the main grids: the d1/Λ values × the angles (9 × 90 = 810)."""
    return len(FRACTIONS) * len(ANGLES)


def batch(grid, period):
    g = GRIDS[grid]
    cos = torch.cos(torch.deg2rad(torch.tensor(ANGLES, dtype=torch.float64)))  # (90,)
    d1 = (torch.tensor(FRACTIONS, dtype=torch.float64) * period)[:, None]  # (9, 1)
    return cos, g["n1"], g["n2"], d1, period - d1, g["cells"]


def _busy_jiffies():
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    return sum(v) - v[3] - v[4], sum(v)  # (busy, total) over all CPUs


def others_busy(window=0.25):
    """CPU cores kept busy by other processes while this one sleeps (from /proc/stat); 0 if unknown."""
    try:
        b0, t0 = _busy_jiffies()
        time.sleep(window)
        b1, t1 = _busy_jiffies()
    except OSError:
        return 0.0
    return (b1 - b0) / max(1, t1 - t0) * (os.cpu_count() or 1)


class Quiet:
    """Wait (bounded) before each timing round until other processes leave the cores idle.

    With 2 torch threads on 2 shared cores, another busy process makes OpenMP regions wait for
    a descheduled thread and a call can be 10–300× slower; those rounds are waited out when the
    budget allows, and counted otherwise."""

    def __init__(self, budget_s, threshold=0.3, patience_s=30.0):
        self.budget, self.threshold, self.patience = budget_s, threshold, patience_s
        self.waited, self.contended, self.rounds = 0.0, 0, 0

    def __call__(self):
        self.rounds += 1
        start = time.perf_counter()
        while True:
            busy = others_busy()
            spent = time.perf_counter() - start
            if busy <= self.threshold:
                break
            if spent >= self.patience or self.waited + spent >= self.budget:
                self.contended += 1
                break
            time.sleep(0.75)
        self.waited += time.perf_counter() - start


def time_rounds(fns, rounds, seed, bar=None, quiet=None):
    """Interleaved timing: per round every fn once (``inner`` calls averaged); returns per-round times."""
    inner = {}
    for key, fn in fns.items():  # warm-up and choose the inner count (≥ ~40 ms per sample)
        t0 = time.perf_counter()
        fn()
        dt = time.perf_counter() - t0
        inner[key] = max(1, min(50, math.ceil(0.04 / max(dt, 1e-6))))
    times = {key: [] for key in fns}
    rng = random.Random(seed)
    keys = list(fns)
    for _ in range(rounds):
        if quiet is not None:
            quiet()
        rng.shuffle(keys)
        for key in keys:
            fn, n = fns[key], inner[key]
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            times[key].append((time.perf_counter() - t0) / n)
        if bar is not None:
            bar.update(1)
    return times


def stats(de):
    de = np.asarray(de, dtype=np.float64).ravel()
    return {"median": float(np.median(de)), "p95": float(np.percentile(de, 95)), "max": float(de.max())}


def measure(args):
    torch.set_num_threads(args.threads)
    cfgs = configs()
    keys = [json.dumps(c, sort_keys=True) for c in cfgs]
    ref_key = keys[0]
    results = {}  # grid -> period -> key -> dict(errors, times, ...)
    refinfo = {}
    from tqdm import tqdm

    quiet = Quiet(args.max_wait)

    total = (sum(len(g["periods"]) for g in GRIDS.values()) * (args.rounds + 1)
             + args.rounds * len(BATCH_CHECK["periods"]))
    with tqdm(total=total, desc="grids × Λ × rounds", file=sys.stdout, mininterval=1.0) as bar:
        for grid, g in GRIDS.items():
            results[grid], refinfo[grid] = {}, {"samples": {}, "ref_samples": {}, "check": {}, "spectral_worst": {}}
            for period in g["periods"]:
                bar.set_postfix_str(f"{grid} Λ={period:.0f} errors")
                cos, n1, n2, d1, d2, N = batch(grid, period)
                # errors are measured against the 2× refinement of the default spectral method
                # (192 samples per fringe), itself checked against the 4× refinement (384)
                ref_lab = xyz_to_lab(ti.bragg_xyz(cos, n1, n2, d1, d2, N, method="spectral",
                                                  samples_per_fringe=REF_SPF, max_samples=1 << 20))
                finer = xyz_to_lab(ti.bragg_xyz(cos, n1, n2, d1, d2, N, method="spectral",
                                                samples_per_fringe=CHECK_SPF, max_samples=1 << 20))
                pk = str(int(period))
                refinfo[grid]["samples"][pk] = spectral_samples(n1, n2, d1, d2, N)
                refinfo[grid]["ref_samples"][pk] = spectral_samples(n1, n2, d1, d2, N, samples_per_fringe=REF_SPF,
                                                                    max_samples=1 << 20)
                refinfo[grid]["check"][pk] = float(delta_e_2000(finer, ref_lab).max())
                fns, errs = {}, {}
                for cfg, key in zip(cfgs, keys):
                    kw = dict(cfg)
                    fn = (lambda kw=kw: ti.bragg_xyz(cos, n1, n2, d1, d2, N, **kw))
                    fns[key] = fn
                    errs[key] = delta_e_2000(xyz_to_lab(fn()), ref_lab).numpy()
                e_spec = errs[ref_key]
                refinfo[grid]["spectral_worst"][pk] = (float(e_spec.max()),
                                                       ANGLES[int(np.unravel_index(e_spec.argmax(), e_spec.shape)[1])])
                bar.update(1)
                bar.set_postfix_str(f"{grid} Λ={period:.0f} timing")
                times = time_rounds(fns, args.rounds, seed=int(period) + len(grid), bar=bar, quiet=quiet)
                base = times[ref_key]
                results[grid][period] = {
                    key: {"errors": errs[key], "times": times[key],
                          "t": statistics.median(times[key]),
                          "speedup": statistics.median(b / t for b, t in zip(base, times[key]))}
                    for key in keys}
        refinfo["batch"] = batch_check(args, quiet, bar)
    refinfo["quiet"] = dict(rounds=quiet.rounds, contended=quiet.contended, waited_s=quiet.waited)
    return cfgs, keys, results, refinfo


BATCH_CHECK = dict(grid="fig4", periods=(244.0, 500.0, 988.0), angles=(90, 270, 900))
# the configurations that decide the verdict at some Λ (sampled K up to the cheapest one at least as
# accurate as the best landmark configuration, K = 512 at 988 nm)
BATCH_CONFIGS = ([{"method": "sampled", "samples": k} for k in (64, 128, 256, 512)]
                 + [{"method": "piecewise", "subdivisions": s, "weights": w, "correction": c}
                    for s, w, c in ((1, "paper", "paper"), (5, "averaged", "fitted"), (8, "averaged", "fitted"),
                                    (12, "averaged", "fitted"), (16, "averaged", "fitted"))]
                 + [{"method": "envelope", "samples": k} for k in (32, 64)])


def batch_check(args, quiet, bar):
    """Per-round µs per colour at 810, 2430 and 8100 colours per call (fig4, each Λ; 90, 270 or 900
    angles 0–89° × the 9 d1/Λ): ``{Λ: {key: {colours: [per-round µs]}}}``."""
    grid = BATCH_CHECK["grid"]
    out = {}
    for period in BATCH_CHECK["periods"]:
        _, n1, n2, d1, d2, N = batch(grid, period)
        fns = {}
        for nang in BATCH_CHECK["angles"]:
            cos = torch.cos(torch.deg2rad(torch.linspace(0, 89, nang, dtype=torch.float64)))
            for cfg in BATCH_CONFIGS:
                fns[(json.dumps(cfg, sort_keys=True), nang)] = (
                    lambda kw=dict(cfg), cos=cos: ti.bragg_xyz(cos, n1, n2, d1, d2, N, **kw))
        bar.set_postfix_str(f"batch-size check, Λ = {period:g} nm")
        times = time_rounds(fns, args.rounds, seed=1, bar=bar, quiet=quiet)
        out[str(int(period))] = {key: {str(9 * nang): [t / (9 * nang) * 1e6 for t in times[(key, nang)]]
                                       for nang in BATCH_CHECK["angles"]}
                                 for key in (json.dumps(c, sort_keys=True) for c in BATCH_CONFIGS)}
    return out


def batch_medians(refinfo):
    """``{Λ: {key: {colours: median µs per colour}}}`` of :func:`batch_check`'s rounds."""
    return {pk: {k: {n: statistics.median(v) for n, v in by.items()} for k, by in per.items()}
            for pk, per in refinfo["batch"].items()}


def summarise(cfgs, keys, results):
    """entries[key][grid] = {median, p95, max, us_per_colour, speedup_vs_spectral, per_period}."""
    entries = {}
    for key in keys:
        entries[key] = {}
        for grid, g in GRIDS.items():
            per = {}
            for period in g["periods"]:
                r = results[grid][period][key]
                per[str(int(period))] = dict(stats(r["errors"]), us_per_colour=r["t"] / colours() * 1e6,
                                             speedup_vs_spectral=r["speedup"])
            allerr = np.concatenate([results[grid][p][key]["errors"].ravel() for p in g["periods"]])
            t_all = sum(results[grid][p][key]["t"] for p in g["periods"])
            t_ref = sum(results[grid][p][keys[0]]["t"] for p in g["periods"])
            entries[key][grid] = dict(stats(allerr), us_per_colour=t_all / (colours() * len(g["periods"])) * 1e6,
                                      speedup_vs_spectral=t_ref / t_all, per_period=per)
    return entries


def pareto(cfgs, keys, entries, grid, pk, metric):
    """For each piecewise/envelope config: sampled configs at least as fast AND at least as accurate;
    the cheapest sampled config at least as accurate and its time ratio."""
    def get(key):
        e = entries[key][grid]
        return e if pk == "all" else e["per_period"][pk]

    sampled = [(c, k) for c, k in zip(cfgs, keys) if c["method"] == "sampled"]
    out = {}
    for c, k in zip(cfgs, keys):
        if c["method"] not in FAST:
            continue
        p = get(k)
        dom = [s["samples"] for s, sk in sampled
               if get(sk)["us_per_colour"] <= p["us_per_colour"] and get(sk)[metric] <= p[metric]]
        as_good = [(get(sk)["us_per_colour"], s["samples"]) for s, sk in sampled if get(sk)[metric] <= p[metric]]
        cheapest = min(as_good) if as_good else None
        out[k] = dict(dominated_by=dom, cheapest=cheapest,
                      ratio=None if cheapest is None else cheapest[0] / p["us_per_colour"])
    return out


def fmt(x, nd=2):
    if x == 0:
        return "0"
    if x >= 100:
        return f"{x:.0f}"
    if x >= 0.01:
        return f"{x:.{nd}f}"
    return f"{x:.1e}"


def tables(cfgs, keys, entries):
    md = {}
    for grid, g in GRIDS.items():
        lines = ["| method | Λ (nm) | median ΔE | p95 ΔE | µs per colour | speed-up vs spectral reference |",
                 "|---|---:|---:|---:|---:|---:|"]
        for pk in [str(int(p)) for p in g["periods"]] + ["all"]:
            for c, k in zip(cfgs, keys):
                e = entries[k][grid] if pk == "all" else entries[k][grid]["per_period"][pk]
                errs = (fmt(e["median"]), fmt(e["p95"]))
                lines.append(f"| {label(c)} | {pk} | {errs[0]} | {errs[1]} | {e['us_per_colour']:.1f} | "
                             f"{e['speedup_vs_spectral']:.2f}× |")
        md[grid] = "\n".join(lines)
    return md


def paper_comparison(cfgs, keys, entries):
    lines = ["| Λ (nm) | source | app. | s = 2 | s = 3 | s = 4 | s = 5 |", "|---:|---|---:|---:|---:|---:|---:|"]
    for period, paper in PAPER_TABLE1.items():
        lines.append(f"| {period} | paper Table 1 | " + " | ".join(f"×{v}" for v in paper) + " |")
        for w, corr in WEIGHTINGS:
            row = []
            for s in (1, 2, 3, 4, 5):
                k = json.dumps({"method": "piecewise", "subdivisions": s, "weights": w, "correction": corr},
                               sort_keys=True)
                row.append(f"×{entries[k]['fig4']['per_period'][str(period)]['speedup_vs_spectral']:.2f}")
            name = "averaged" if w == "averaged" else f"paper/{corr}"
            lines.append(f"| {period} | ours, {name} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def rounds_won(results, grid, pk, fast_key, slow_key):
    """(rounds in which ``slow_key`` took longer than ``fast_key``, rounds): paired by round (the
    methods of one round run back to back, interleaved), per Λ; None for the pooled "all" rows."""
    if results is None or pk == "all":
        return None
    r = results[grid][float(pk)]
    pairs = list(zip(r[fast_key]["times"], r[slow_key]["times"]))
    return sum(ts > tf for tf, ts in pairs), len(pairs)


def pareto_text(cfgs, keys, entries, results=None):
    """Markdown statement per grid and Λ, computed from the measurements; with ``results`` the
    decisive comparisons also say in how many timing rounds they held."""
    lines = ["| grid | Λ (nm) | approximations on the front (p95) | on the front (median) | "
             "best piecewise vs cheapest sampled K at least as accurate (p95) | best envelope, same |",
             "|---|---:|---|---|---|---|"]
    summary = {}
    sampled_key = {c["samples"]: k for c, k in zip(cfgs, keys) if c["method"] == "sampled"}
    for grid, g in GRIDS.items():
        for pk in [str(int(p)) for p in g["periods"]] + ["all"]:
            fr, best = {}, {}
            cfg_of = dict(zip(keys, cfgs))
            for metric in ("p95", "median"):
                res = pareto(cfgs, keys, entries, grid, pk, metric)
                fr[metric] = [k for k, v in res.items() if not v["dominated_by"]]
                if metric == "p95":
                    for fam in FAST:
                        mine = [kv for kv in res.items() if cfg_of[kv[0]]["method"] == fam]
                        best[fam] = max(mine, key=lambda kv: (kv[1]["ratio"] if kv[1]["ratio"] is not None
                                                              else math.inf))

            def names(ks):
                return ", ".join(label(cfg_of[k]).replace("piecewise ", "") for k in ks) or "**none**"

            def compare(bk, bv):
                if bv["cheapest"] is None:
                    return f"{label(cfg_of[bk])}: no sampled K ≤ 2048 is as accurate"
                e = entries[bk][grid] if pk == "all" else entries[bk][grid]["per_period"][pk]
                won = rounds_won(results, grid, pk, bk, sampled_key[bv["cheapest"][1]])
                return (f"{label(cfg_of[bk])} (p95 {fmt(e['p95'])}) vs sampled K={bv['cheapest'][1]}: "
                        f"sampled takes {bv['ratio']:.2f}× the time"
                        + ("" if won is None else f" (longer in {won[0]} of {won[1]} rounds)"))
            lines.append(f"| {grid} | {pk} | {names(fr['p95'])} | {names(fr['median'])} | "
                         f"{compare(*best['piecewise'])} | {compare(*best['envelope'])} |")
            summary[(grid, pk)] = {
                fam: dict(front_p95=sum(cfg_of[k]["method"] == fam for k in fr["p95"]),
                          front_median=sum(cfg_of[k]["method"] == fam for k in fr["median"]),
                          ratio=best[fam][1]["ratio"],
                          won=None if best[fam][1]["cheapest"] is None else
                          rounds_won(results, grid, pk, best[fam][0], sampled_key[best[fam][1]["cheapest"][1]]))
                for fam in FAST}
    cells = [(k, v) for k, v in summary.items() if k[1] != "all"]
    verdicts = []
    for fam in FAST:
        on = [f"{g} Λ = {pk}" for (g, pk), v in cells if v[fam]["front_p95"] or v[fam]["front_median"]]
        off = [f"{g} Λ = {pk}" for (g, pk), v in cells if not (v[fam]["front_p95"] or v[fam]["front_median"])]
        name = "Piecewise (landmark)" if fam == "piecewise" else "Envelope"
        if on:
            verdicts.append(f"{name} configurations are on the front for: {', '.join(on)}"
                            + (f"; not for: {', '.join(off)}." if off else " (every grid and Λ)."))
        else:
            verdicts.append(f"**No {name.lower()} configuration is on the front for any grid and Λ** (p95 or median).")
        ratios = [(v[fam]["ratio"], k, v[fam]["won"]) for k, v in cells if v[fam]["ratio"] is not None]
        if ratios:
            r, (g, pk), won = min(ratios, key=lambda t: t[0])  # the cell where the family's best configuration fares worst
            verdicts[-1] += (f" Worst cell ({fam}): {g} Λ = {pk} nm, where the cheapest sampled K at least as "
                             f"accurate (p95) as its best configuration takes {r:.2f}× its time"
                             + ("" if won is None else f", longer in {won[0]} of {won[1]} paired rounds")
                             + (" (dominated there)." if r < 1 else
                                f" (timings would have to move by more than {r:.1f}× to change the verdict)."))
    verdict = "\n\n".join(verdicts)
    return "\n".join(lines) + "\n\n" + verdict, summary


def batch_text(entries, refinfo):
    """Batch-size sensitivity: per Λ, µs per colour at each batch size and the domination verdict
    recomputed with the times at that size and the errors of the main (810-colour) grid (the error
    distribution does not depend on the angular step); then, per Λ and size, the best landmark
    configuration against the cheapest sampled K at least as accurate (p95), with paired rounds."""
    grid = BATCH_CHECK["grid"]
    sizes = [str(9 * a) for a in BATCH_CHECK["angles"]]
    med = batch_medians(refinfo)
    out, verdict = [], ["| Λ (nm) | " + " | ".join(f"{n} colours per call" for n in sizes) + " |",
                        "|---:|" + "---|" * len(sizes)]
    for pk, bt in med.items():
        rounds = refinfo["batch"][pk]

        def p95(c):
            return entries[json.dumps(c, sort_keys=True)][grid]["per_period"][pk]["p95"]
        lines = [f"Λ = {pk} nm:", "",
                 "| method | p95 ΔE | " + " | ".join(f"µs per colour, {n} per call" for n in sizes)
                 + " | " + " | ".join(f"dominated by sampled ({n} per call)" for n in sizes) + " |",
                 "|---|---:|" + "---:|" * len(sizes) + "---|" * len(sizes)]
        sampled = [c for c in BATCH_CONFIGS if c["method"] == "sampled"]
        cells = []
        for n in sizes:
            best = None  # (ratio, cfg, sampled cfg) of the landmark configuration with the largest margin
            for cfg in BATCH_CONFIGS:
                if cfg["method"] != "piecewise":
                    continue
                k = json.dumps(cfg, sort_keys=True)
                acc = [c for c in sampled if p95(c) <= p95(cfg)]
                if not acc:
                    continue
                cheap = min(acc, key=lambda c: bt[json.dumps(c, sort_keys=True)][n])
                r = bt[json.dumps(cheap, sort_keys=True)][n] / bt[k][n]
                if best is None or r > best[0]:
                    best = (r, cfg, cheap)
            if best is None:
                cells.append("no sampled K ≤ 512 is as accurate as any landmark configuration")
                continue
            r, cfg, cheap = best
            fast = rounds[json.dumps(cfg, sort_keys=True)][n]
            slow = rounds[json.dumps(cheap, sort_keys=True)][n]
            won = sum(ts > tf for tf, ts in zip(fast, slow))
            cells.append(f"{label(cfg).replace('piecewise ', '')} vs K={cheap['samples']}: sampled takes "
                         f"{r:.2f}× the time (longer in {won} of {len(fast)} rounds)")
        verdict.append(f"| {pk} | " + " | ".join(cells) + " |")
        for cfg in BATCH_CONFIGS:
            k = json.dumps(cfg, sort_keys=True)
            dom = []
            for n in sizes:
                if cfg["method"] not in FAST:
                    dom.append("")
                    continue
                ks = [c["samples"] for c in sampled
                      if bt[json.dumps(c, sort_keys=True)][n] <= bt[k][n] and p95(c) <= p95(cfg)]
                dom.append(", ".join(f"K={x}" for x in ks) or "**no** (on the front)")
            lines.append(f"| {label(cfg)} | {fmt(p95(cfg))} | " + " | ".join(f"{bt[k][n]:.1f}" for n in sizes)
                         + " | " + " | ".join(dom) + " |")
        out.append("\n".join(lines))
    return ("Best landmark configuration against the cheapest sampled K at least as accurate (p95), by batch size:\n\n"
            + "\n".join(verdict) + "\n\n<details><summary>Per Λ and batch size</summary>\n\n"
            + "\n\n".join(out) + "\n\n</details>")


def plot(cfgs, keys, entries, path, args, resolution=0.05):
    YMIN = 5e-3
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"sampled": ("C0", "o"), "piecewise paper/paper": ("C3", "s"),
              "piecewise paper/fitted": ("C1", "D"), "piecewise averaged": ("C2", "^"), "envelope": ("C4", "v")}
    fig, axes = plt.subplots(2, 3, figsize=(15, 9), constrained_layout=True)
    for row, (grid, g) in enumerate(GRIDS.items()):
        for col, period in enumerate(g["periods"]):
            ax = axes[row, col]
            pk = str(int(period))
            for fam, (colour, marker) in styles.items():
                sel = [(c, k) for c, k in zip(cfgs, keys) if family(c) == fam]
                xs = [entries[k][grid]["per_period"][pk]["us_per_colour"] for _, k in sel]
                p95 = [entries[k][grid]["per_period"][pk]["p95"] for _, k in sel]
                med = [entries[k][grid]["per_period"][pk]["median"] for _, k in sel]
                ax.plot(xs, p95, marker=marker, color=colour, ls="-", label=f"{fam} (p95)")
                ax.plot(xs, med, marker=marker, color=colour, ls=":", mfc="none", alpha=0.7,
                        label=f"{fam} (median)")
                if fam == "piecewise paper/fitted":
                    continue  # nearly on top of paper/paper: not annotated
                left = fam == "piecewise paper/paper"
                for (c, _), x, y in zip(sel, xs, p95):
                    ann = f"K={c['samples']}" if "samples" in c else f"s={c['subdivisions']}"
                    ax.annotate(ann, (x, y), textcoords="offset points", xytext=(-4, 0) if left else (4, 4),
                                ha="right" if left else "left", va="center" if left else "bottom",
                                fontsize=7, color=colour)
            tref = entries[keys[0]][grid]["per_period"][pk]["us_per_colour"]
            ax.axvline(tref, color="k", ls="--", lw=1, label="spectral reference (time)")
            ax.axhline(1.0, color="grey", ls="-.", lw=0.8, label="ΔE2000 = 1")
            ax.axhspan(YMIN, resolution, color="grey", alpha=0.12, lw=0,
                       label="below the reference's resolution")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_ylim(bottom=YMIN)
            ax.set_xlabel(f"µs per colour ({threads_text(args)})")
            ax.set_ylabel("ΔE2000 vs spectral reference")
            ax.set_title(f"{grid}: n2 = {g['n2']}, N = {g['cells']}, Λ = {pk} nm")
            ax.grid(True, which="both", alpha=0.3)
    h, lab = axes[0, 0].get_legend_handles_labels()
    fig.legend(h, lab, loc="outside lower center", ncol=6, fontsize=8)
    fig.suptitle("Bragg mirror colour: speed against error (Fourneau Fig. 4 grid and a dense grid; "
                 "filled/solid: p95, open/dotted: median; values below 5e-3 are off the axes)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)
    plt.close(fig)


def threads_text(args):
    return f"{args.threads} thread" + ("s" if args.threads != 1 else "") + (
        f", CPUs {args.cpus_used}" if args.cpus else "")


def pin_text(args):
    return f" pinned to CPUs {args.cpus_used} (`--cpus`)" if args.cpus else ""


def allocator(args):
    if args.malloc == "tuned":
        return "glibc allocator tuned (MALLOC_MMAP_THRESHOLD_=MALLOC_TRIM_THRESHOLD_=2^30, set by the script)"
    return "glibc allocator defaults"


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            return next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or platform.machine()


def section(md, comparison, front, batchmd, entries, refinfo, args, elapsed):
    g4, gd = GRIDS["fig4"], GRIDS["dense"]
    spec = json.dumps({"method": "spectral"}, sort_keys=True)
    ref = "; ".join(f"{grid}: " + ", ".join(f"{refinfo[grid]['samples'][pk]} → {refinfo[grid]['ref_samples'][pk]}"
                                            for pk in refinfo[grid]["samples"])
                    for grid in GRIDS)
    chk = max(v for grid in GRIDS for v in refinfo[grid]["check"].values())
    spec_max = max(entries[spec][grid]["max"] for grid in GRIDS)
    spec_p95 = max(entries[spec][grid]["p95"] for grid in GRIDS)
    worst = max((v for grid in GRIDS for v in refinfo[grid]["spectral_worst"].values()), key=lambda v: v[0])
    big = sorted({v[1] for grid in GRIDS for v in refinfo[grid]["spectral_worst"].values() if v[0] > 0.5 * worst[0]})
    where = (f"the largest deviation ({worst[0]:.3f}) is at θ = {worst[1]}°"
             + ("" if big == [worst[1]] else f"; deviations above half of it at θ ∈ {{{', '.join(map(str, big))}}}°"))
    resol = max(0.05, 2 * chk)
    app = json.dumps({"method": "piecewise", "subdivisions": 1, "weights": "paper", "correction": "paper"},
                     sort_keys=True)
    ours = [entries[app]["fig4"]["per_period"][str(p)]["speedup_vs_spectral"] for p in PAPER_TABLE1]
    paper = [v[0] for v in PAPER_TABLE1.values()]

    def trend(v):
        return "rise" if all(b > a for a, b in zip(v, v[1:])) else (
            "fall" if all(b < a for a, b in zip(v, v[1:])) else "are not monotonic")
    trend_txt = (f"Our app. (paper/paper) speed-ups {trend(ours)} with Λ "
                 f"(×{ours[0]:.1f} → ×{ours[-1]:.1f}), the paper's {trend(paper)} (×{paper[0]} → ×{paper[-1]}).")
    q = refinfo["quiet"]
    quiet = (f"Before each round the script waits (bounded) until other processes leave the cores idle "
             f"({args.threads} torch thread(s) on shared cores can slow down by orders of magnitude next to a busy process); "
             f"{q['contended']} of {q['rounds']} rounds still ran next to one ({q['waited_s']:.0f} s waited).")
    cmd = args.command
    table = ("The same run writes `src/torchirid/data/bragg_color_errors.json` (these numbers, for method\n"
             "selection; schema in `luts/build_bragg_color_errors.py`) and the figure below."
             if getattr(args, "json_written", False) else
             "`src/torchirid/data/bragg_color_errors.json` (the numbers `method=\"auto\"` selects from) is built from\n"
             "this measurement by `luts/build_bragg_color_errors.py`. This run wrote the figure below.")
    return f"""{START}
## Bragg mirror colour (Fourneau Fig. 4 grid)

All figures of this section from one run of

```bash
.venv/bin/{cmd}
```

on {datetime.date.today().isoformat()}: {cpu_name()}, {os.cpu_count()} cores, torch {torch.__version__},
Python {platform.python_version()}, `torch.set_num_threads({args.threads})`{pin_text(args)}, float64, {allocator(args)};
whole run {elapsed:.0f} s.
{table}

Grids: **fig4** = Fourneau et al. 2024 Fig. 4, n1 = {g4['n1']:g}, n2 = {g4['n2']:g}, N = {g4['cells']} cells;
**dense** = n2 = {gd['n2']:g}, N = {gd['cells']} (more fringes). Both: Λ ∈ {{244, 500, 988}} nm,
d1/Λ ∈ {{0.1, …, 0.9}}, d2 = Λ − d1, θ = 0–89° in 1° steps, unpolarized, D65 / CIE 1931 2°,
380–780 nm. Each method is **one** `torchirid.bragg_xyz` call per Λ on the 9 × 90 broadcast batch
(810 colours); µs per colour = call time / 810, median of {args.rounds} interleaved rounds; speed-up =
median of the per-round ratios to `method="spectral"` (default settings, 192 ω samples per fringe);
"all" rows pool the three Λ (times summed). {quiet}

Errors are ΔE2000 (CIE Lab, D65 white) against the spectral integration at the default
sampling (192 samples per fringe, the error reference; ω samples for the worst mirror of each batch, default → reference:
{ref}), which is itself within {chk:.3f} ΔE2000 of 2× that sampling (384 per fringe) everywhere. The default
`spectral` method is within {spec_max:.3f} (max) / {spec_p95:.3f} (p95) of it; {where}.
Errors below ~{resol:.2f} are at the reference's resolution (shaded in the figure).

Methods: `sampled` K = K wavelengths uniform in λ; `piecewise` app. (s = 1) and sub. (s > 1):
"paper/paper" is the published method (weights w̃·R^e, the paper's angular-correction
coefficients), "paper/fitted" the same with the library's fitted correction, "averaged" the
library default (fringe-averaged weights, exact finite-N reflectance inside gaps; the correction
is not used); `envelope` K: the same fringe-averaged model as "averaged", sampled at K nodes
uniform in ω and integrated exactly against the CMFs as a piecewise-linear function (no
landmarks; `torchirid.spectral.envelope`).

![speed against error](../../docs/figures/bragg_color_speed_vs_error.png)

### Pareto front (computed)

A piecewise or envelope configuration is on the front when no `sampled` K is both at least as
fast and at least as accurate (same Λ, same run); the last two columns take, per family, the
configuration with the largest time advantage over the cheapest sampled K that is at least as
accurate in p95 (sampled taking < 1× the time = dominated).

{front}

**Batch size.** The verdict above is for 810 colours per call (one call per Λ, Fig. 4's 90 angles).
Same run, fig4, every Λ, {", ".join(str(a) for a in BATCH_CHECK["angles"])} angles (0–89°) × the 9 d1/Λ, i.e.
{", ".join(str(9 * a) for a in BATCH_CHECK["angles"])} colours per call (the whole Fig. 4 grid is 2430 colours); domination recomputed with the
times at each batch size and the errors of the 810-colour grid. The landmark method's time per colour
falls with the batch size (a fixed cost of ~1–2 ms per call: `benchmarks/bragg_color_scaling.py`). At 810 colours
most elementwise ops of the landmark method have fewer entries than torch's parallel grain (32768),
so they run on one thread, while those of `sampled` (colours × K entries) run on all. `sampled`
materialises a (colours × K) reflectance, whose per-colour cost grows on large batches
(memory traffic; with glibc's default allocator also page faults, see the allocator note above:
`--malloc default` measures that setting).

{batchmd}

### Against the paper's Table 1

Fourneau et al. 2024, §5: "our basic and subdivided approximations can be respectively up to ten
and five times faster than the reference"; Table 1 gives app. ×10.6 / ×6.8 / ×4.2 for Λ = 244 /
500 / 988 nm, and sub. s = 2, 3, 4, 5: ×8.8 / 5.5 / 4.5 / 3.8 (244 nm), ×5.0 / 3.5 / 2.6 / 2.1
(500 nm), ×3.8 / 3.1 / 2.4 / 1.7 (988 nm). Ours, fig4 grid, over the default spectral method:

{comparison}

The references differ: the paper's is its own spectral renderer (the text does not give its
wavelength sampling), ours the converged 96-samples-per-fringe integration, whose cost grows
with N·Λ·n (more fringes), while the piecewise cost grows only with the number of landmarks.
{trend_txt} The ratios are not like for like, and neither says anything about accuracy: that is
the Pareto table's job. On this shared VM the speed-ups of this table moved by up to ~1.6× between
runs of the same code (small-op-bound piecewise calls and memory-bound spectral calls
drift differently).

<details><summary>Full table, fig4 grid (n2 = {g4['n2']:g}, N = {g4['cells']})</summary>

{md['fig4']}

</details>

<details><summary>Full table, dense grid (n2 = {gd['n2']:g}, N = {gd['cells']})</summary>

{md['dense']}

</details>
{END}
"""


def write_section(text):
    old = PERF_MD.read_text() if PERF_MD.exists() else "# Performance: speed against error\n"
    if START in old and END in old:
        head, rest = old.split(START, 1)
        tail = rest.split(END, 1)[1].lstrip("\n")
        new = head + text.rstrip("\n") + "\n" + (("\n" + tail) if tail else "")
    else:
        new = old.rstrip("\n") + "\n\n" + text
    tmp = PERF_MD.with_suffix(".md.tmp")
    tmp.write_text(new)
    os.replace(tmp, PERF_MD)
    print(f"wrote {PERF_MD.relative_to(ROOT)}")


def parser(description=None):
    """The measurement's options (this script's and luts/build_bragg_color_errors.py's)."""
    ap = argparse.ArgumentParser(description=description or __doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=7, help="interleaved timing rounds (median; ≥ 5)")
    ap.add_argument("--malloc", choices=("tuned", "default"), default="tuned",
                    help="glibc allocator: 'tuned' (default) re-runs this script with MALLOC_MMAP_THRESHOLD_ = "
                         "MALLOC_TRIM_THRESHOLD_ = 2^30 so that MB-sized temporaries are not mmap'ed and page-faulted "
                         "afresh on every call (glibc's adaptive threshold otherwise makes times bimodal); "
                         "'default' leaves glibc as it is")
    ap.add_argument("--threads", type=int, default=2, help="torch threads (default 2)")
    ap.add_argument("--cpus", default=None,
                    help="pin the process to these CPUs, e.g. '0' or '0,1' (os.sched_setaffinity; default: not pinned)")
    ap.add_argument("--max-wait", type=float, default=150.0,
                    help="seconds in all spent waiting for other processes to leave the cores idle before rounds")
    return ap


def setup(ap, args, raw, script, min_rounds=5):
    """Re-run ``script`` with the wanted allocator if needed (glibc reads it at start-up), check
    the options, pin the CPUs."""
    tuned = os.environ.get("MALLOC_MMAP_THRESHOLD_") == MALLOC and os.environ.get("MALLOC_TRIM_THRESHOLD_") == MALLOC
    if (args.malloc == "tuned") != tuned:  # glibc reads these at start-up: run again with the wanted setting
        env = dict(os.environ)
        if args.malloc == "tuned":
            env.update(MALLOC_MMAP_THRESHOLD_=MALLOC, MALLOC_TRIM_THRESHOLD_=MALLOC)
        else:
            env.pop("MALLOC_MMAP_THRESHOLD_", None)
            env.pop("MALLOC_TRIM_THRESHOLD_", None)
        sys.stdout.flush()
        os.execve(sys.executable, [sys.executable, os.path.abspath(script), *raw], env)
    if args.rounds < min_rounds:
        ap.error(f"--rounds must be >= {min_rounds}")
    if args.threads < 1:
        ap.error("--threads must be >= 1")
    if args.cpus:
        try:
            os.sched_setaffinity(0, {int(c) for c in args.cpus.split(",")})
        except (ValueError, OSError) as exc:
            ap.error(f"--cpus {args.cpus!r}: {exc}")
    args.cpus_used = sorted(os.sched_getaffinity(0))


def run(args):
    """The measurement: ``(cfgs, keys, results, refinfo, entries, elapsed)``."""
    t0 = time.perf_counter()
    cfgs, keys, results, refinfo = measure(args)
    entries = summarise(cfgs, keys, results)
    return cfgs, keys, results, refinfo, entries, time.perf_counter() - t0


def report(cfgs, keys, results, refinfo, entries, elapsed, args, write=True):
    """Print the tables; with ``write``, write the figure and the section of benchmarks/results/bragg_color.md."""
    md = tables(cfgs, keys, entries)
    comparison = paper_comparison(cfgs, keys, entries)
    front, _ = pareto_text(cfgs, keys, entries, results)
    batchmd = batch_text(entries, refinfo)
    for grid in GRIDS:
        print(f"\n### {grid}\n\n{md[grid]}")
    print("\nspectral samples / error-reference samples / max ΔE of the error reference vs its 2× refinement:",
          {g: (refinfo[g]["samples"], refinfo[g]["ref_samples"], {k: round(v, 4) for k, v in refinfo[g]["check"].items()})
           for g in GRIDS})
    print(f"\n### Pareto front\n\n{front}\n\n### Batch size\n\n{batchmd}\n\n### Paper Table 1\n\n{comparison}\n")
    print(f"measured in {elapsed:.0f} s; timing rounds: {refinfo['quiet']}")
    if write:
        chk = max(v for g in GRIDS for v in refinfo[g]["check"].values())
        plot(cfgs, keys, entries, FIGURE, args, resolution=max(0.05, 2 * chk))
        print(f"wrote {FIGURE.relative_to(ROOT)}")
        write_section(section(md, comparison, front, batchmd, entries, refinfo, args, elapsed))


def main(argv=None):
    ap = parser()
    ap.add_argument("--no-write", action="store_true",
                    help="print only: do not write the figure or benchmarks/results/bragg_color.md")
    args = ap.parse_args(argv)
    raw = list(sys.argv[1:] if argv is None else argv)
    args.argv = [a for a in raw if a != "--no-write"]
    args.command = " ".join(["python benchmarks/bragg_color_speed_vs_error.py", *args.argv])
    setup(ap, args, raw, __file__)
    report(*run(args), args, write=not args.no_write)
    print("(the table method=\"auto\" reads, src/torchirid/data/bragg_color_errors.json, is built from this "
          "measurement by luts/build_bragg_color_errors.py)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
