"""torchirid.design against the photonics optimisers, on the peers' own problems and costs.

    .venv/bin/python benchmarks/design.py [--seeds 5] [--only bragg,chirped,pv,colour,forward,robust,tolerance]
                                          [--quick] [--out benchmarks/results/design]

Everything runs in one process, single-threaded (torch and NumPy), peers and torchirid
alternating seed by seed (paired rounds: a ratio per round, medians reported). Every design —
torchirid's included — is scored by the peer's own code (benchmarks/design_peers.py):

* ``bragg`` N = 10, 20, 40 (PyMoosh): PyMoosh's QODE with 20 000 evaluations, the time at which
  its running best first reaches the quarter-wave optimum to 1e-3 (``seconds_to_target``);
  torchirid's ``optimise`` with its own stopping rule (``seconds``) and with ``goal`` = that
  target. Also nevergrad's TwoPointsDE, cuda-thinfilm's DE and an Adam loop on difftmm (N = 20).
* ``chirped`` D = 20, 40, 60 (nevergrad's problem, bounds [0, 300] nm): QODE with 20 000
  evaluations scored by PyMoosh's vectorised spectrum; torchirid with ``time_limit`` = a tenth of
  QODE's time in the same round.
* ``pv`` N = 10, 20 (PyMoosh's photovoltaic AR coating on a-Si, cost 1 − Jsc/Jsc,max by
  ``PyMoosh.photo``, 0.14 s per evaluation): QODE with a 150-evaluation budget (what fits in
  ~20 s), cuda-thinfilm's DE, difftmm's Adam, torchirid with a 5 s limit.
* ``colour``: the CIELAB of a 6-layer TiO2/SiO2 stack on glass at 0°, 30°, 60° as targets; the
  time until the design is within ΔE2000 1.0 at every angle, checked with tmm + colour-science.
* ``tolerance``: the yield under σ = 1 nm against an independent tmm Monte Carlo.
* ``robust``: fabtwin's CVaR design and torchirid's ``Robust(objective="cvar")`` on bragg(20)
  with 1-nm errors, both scored on the same 4096 draws.
* ``forward``: R of 1000 stacks × 20 layers × 50 wavelengths by torchirid.multilayer, difftmm,
  cuda-thinfilm (NumPy) and PyMoosh, checked against tmm.

Writes ``OUT.json`` (every run), ``OUT.md`` (the tables for docs/performance.md) and
``docs/figures/design_merit_time.png`` (best merit against wall time).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

# one thread everywhere (set before NumPy loads its BLAS): every code in the comparison runs on one
# core, and a second BLAS thread fighting other tenants' work would time the machine, not the code
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks import design_peers as peers
from torchirid import design

ROOT = Path(__file__).resolve().parents[1]


def to_problem(pp: peers.PeerProblem, **kw) -> design.Problem:
    """The peer's problem as a torchirid design problem: the same media, wavelengths, angle,
    polarization, bounds and cost (p = 1: the peers' 1 − mean R, or the photon-weighted 1 − A)."""
    layers = [design.Layer(complex(n) if isinstance(n, complex) else float(n), (float(lo), float(hi)))
              for n, lo, hi in zip(pp.layer_indices, pp.lower, pp.upper)]
    cos = math.cos(math.radians(pp.angle_deg))
    if pp.cost_kind == "1-Jsc/Jsc_max":  # A in a-Si = T into it (it absorbs all it receives)
        ex = pp.exit_values
        sub = {"wavelength": pp.wavelengths, "n": ex.real, "k": ex.imag}
        target = design.SpectralTarget("T", pp.wavelengths, 1.0, cos_theta=cos, polarization=pp.polarization,
                                       weight=pp.weights, p=1)
    else:
        sub = float(pp.exit_index)
        target = design.SpectralTarget("R", pp.wavelengths, 1.0, cos_theta=cos, polarization=pp.polarization, p=1)
    return design.Problem(layers, [target], n_incident=float(pp.incident_index), n_substrate=sub, **kw)


def ours(problem: design.Problem, pp: peers.PeerProblem, seed: int, score=None, **kw) -> dict:
    d = design.optimise(problem, seed=seed, **kw)
    x = np.array(d.thicknesses)
    return {"x": x.tolist(), "cost": float((score or pp.cost)(x)), "merit": d.merit, "seconds": d.seconds,
            "evaluations": d.evaluations, "history": [list(h) for h in d.history]}


def _clean(r: dict) -> dict:
    out = {}
    for k, v in r.items():
        if isinstance(v, np.ndarray):
            v = v.tolist()
        if isinstance(v, (np.floating, np.integer)):
            v = v.item()
        if k == "history":
            v = [[float(a) for a in h] for h in v]
        out[k] = v
    return out


def med(values) -> float:
    v = [x for x in values if x is not None]
    return float(np.median(v)) if v else float("nan")


def spread(values) -> str:
    v = [x for x in values if x is not None]
    return f"{min(v):.3g}–{max(v):.3g}" if v else "–"


# ------------------------------------------------------------------------------------------
def bench_bragg(seeds, quick, log):
    rows = []
    for n in (10, 20, 40):
        pp = peers.bragg(n)
        target = pp.known_optimum * (1 + 1e-3)
        prob = to_problem(pp)
        design.optimise(prob, seed=99)  # warm-up (first autograd call, SciPy import)
        for s in seeds:
            order = ("peer", "ours") if s % 2 == 0 else ("ours", "peer")
            res = {}
            for who in order:
                if who == "peer":
                    res["qode"] = peers.run_qode(pp, 20000, s, target=target)
                else:
                    res["ours"] = ours(prob, pp, s)
                    res["ours_goal"] = ours(prob, pp, s, goal=target)
            if n == 20 and not quick and s < 3:
                res["nevergrad_TwoPointsDE"] = peers.run_nevergrad(pp, 10000, s, optimizer="TwoPointsDE", target=target)
                res["cuda_thinfilm_de"] = peers.run_cuda_thinfilm(pp, 20000, s, method="de", target=target)
                res["difftmm_adam"] = peers.run_difftmm_adam(pp, 1000, s, target=target, starts=16)
            row = {"problem": f"bragg{n}", "seed": s, **{k: _clean(v) for k, v in res.items()}}
            q, o, g = res["qode"], res["ours"], res["ours_goal"]
            log(f"bragg{n} seed {s}: QODE {q['cost']:.9g} to-target {q['seconds_to_target']} s | ours {o['cost']:.9g} "
                f"in {o['seconds']:.3f} s (goal: {g['seconds']:.3f} s, {g['cost']:.9g})")
            rows.append(row)
    return rows


def bench_chirped(seeds, quick, log):
    rows = []
    for D in (20, 40) if quick else (20, 40, 60):
        pp = peers.chirped(D)
        prob = to_problem(pp)
        design.optimise(prob, seed=99, time_limit=0.3)
        for s in seeds:
            q = peers.run_qode(pp, 20000, s)
            q["cost_pymoosh"] = float(pp.cost_pymoosh(np.asarray(q["x"])))
            o = ours(prob, pp, s, score=pp.cost_pymoosh, time_limit=q["seconds"] / 10)
            row = {"problem": f"chirped{D}", "seed": s, "qode": _clean(q), "ours": _clean(o)}
            if D == 20 and not quick and s < 3:
                row["nevergrad_TwoPointsDE"] = _clean(peers.run_nevergrad(pp, 20000, s, optimizer="TwoPointsDE"))
                row["cuda_thinfilm_de"] = _clean(peers.run_cuda_thinfilm(pp, 20000, s, method="de"))
                row["difftmm_adam"] = _clean(peers.run_difftmm_adam(pp, 1000, s, starts=16))
            log(f"chirped{D} seed {s}: QODE {q['cost_pymoosh']:.6f} in {q['seconds']:.1f} s | ours {o['cost']:.6f} "
                f"in {o['seconds']:.2f} s")
            rows.append(row)
    return rows


def bench_pv(seeds, quick, log):
    rows = []
    for n in (10,) if quick else (10, 20):
        pp = peers.photovoltaic(n)
        prob = to_problem(pp)
        design.optimise(prob, seed=99, time_limit=0.3)
        for s in seeds[:3]:
            o = ours(prob, pp, s, time_limit=5.0)
            row = {"problem": f"pv{n}", "seed": s, "ours": _clean(o)}
            q = peers.run_qode(pp, 150, s)
            row["qode"] = _clean(q)
            row["cuda_thinfilm_de"] = _clean(peers.run_cuda_thinfilm(pp, 3000, s, method="de"))
            if not quick:
                row["difftmm_adam"] = _clean(peers.run_difftmm_adam(pp, 333, s, starts=8))
            log(f"pv{n} seed {s}: ours {o['cost']:.5f} in {o['seconds']:.1f} s | QODE(150) {q['cost']:.5f} in "
                f"{q['seconds']:.1f} s | cuda-thinfilm DE {row['cuda_thinfilm_de']['cost']:.5f} in "
                f"{row['cuda_thinfilm_de']['seconds']:.1f} s")
            rows.append(row)
    return rows


def _tmm_lab(materials, thicknesses, angles_deg):
    sys.path.insert(0, str(ROOT / "tests"))
    from oracles import colour_lab, material_nk, tmm_RT

    lam = np.arange(360.0, 781.0, 5.0)
    out = []
    for a in angles_deg:
        R = [tmm_RT(w, math.cos(math.radians(a)),
                    [1.0] + [complex(material_nk(m, w)) for m in materials] + [complex(material_nk("SiO2", w))],
                    list(thicknesses), "unpolarized")[0] for w in lam]
        out.append(colour_lab(lam, R))
    return np.array(out)


COLOUR_STACK = (["TiO2", "SiO2"] * 3, [95.0, 140.0, 60.0, 180.0, 110.0, 75.0])


def bench_colour(seeds, quick, log):
    import colour

    angles = [0.0, 30.0, 60.0]
    mats, ref = COLOUR_STACK
    target = _tmm_lab(mats, ref, angles)
    prob = design.Problem([design.Layer(m, (10, 250)) for m in mats],
                          [design.ColourTarget(target, cos_theta=np.cos(np.radians(angles)))], n_substrate="glass")
    rows = []
    for s in seeds:
        d = design.optimise(prob, seed=s, time_limit=60, goal=0.2)
        de = colour.delta_E(target, _tmm_lab(d.materials, d.thicknesses, angles), method="CIE 2000")
        log(f"colour seed {s}: {d.seconds:.1f} s, merit {d.merit:.3f}, ΔE2000 (tmm + colour-science) "
            f"{np.round(de, 3).tolist()}")
        rows.append({"problem": "colour6", "seed": s, "seconds": d.seconds, "merit": d.merit,
                     "delta_e": de.tolist(), "thicknesses": d.thicknesses, "evaluations": d.evaluations,
                     "history": [list(h) for h in d.history]})
    return rows


def bench_tolerance(seeds, quick, log):
    sys.path.insert(0, str(ROOT / "tests"))
    from oracles import tmm_RT

    qw = [600 / (4 * n) for n in (1.8, 1.4) * 4]
    lam = (580.0, 600.0, 620.0)
    prob = design.Problem([design.Layer(m, d) for m, d in zip((1.8, 1.4) * 4, qw)],
                          [design.SpectralTarget("R", list(lam), value=1.0, p=1)], n_substrate=1.8)

    def merit(d):
        return np.mean([1 - tmm_RT(w, 1.0, [1.0, *(1.8, 1.4) * 4, 1.8], list(d), "unpolarized")[0] for w in lam])

    limit = merit(qw) * 1.001
    t0 = time.perf_counter()
    t = design.tolerance(prob, sigma=1.0, samples=20000, seed=0, merit_limit=limit)
    ours_s = time.perf_counter() - t0
    rng = np.random.default_rng(12345)
    draws = np.clip(np.array(qw) + rng.standard_normal((3000 if quick else 10000, 8)), 0, None)
    t0 = time.perf_counter()
    ref = float(np.mean([merit(d) <= limit for d in draws]))
    tmm_s = time.perf_counter() - t0
    log(f"tolerance: yield {100 * t.yield_fraction:.2f} % ± {100 * t.standard_error:.2f} (20 000 draws, {ours_s:.2f} s)"
        f" vs tmm {100 * ref:.2f} % ({len(draws)} draws, {tmm_s:.1f} s)")
    return [{"problem": "tolerance", "yield": t.yield_fraction, "standard_error": t.standard_error,
             "tmm_yield": ref, "tmm_draws": len(draws), "seconds": ours_s, "tmm_seconds": tmm_s}]


def bench_robust(seeds, quick, log):
    pp = peers.bragg(20)
    prob = to_problem(pp, robust=design.Robust(sigma=1.0, samples=128, objective="cvar", alpha=0.1, seed=0))
    rows = []
    g = np.random.default_rng(7)
    errors = g.standard_normal((4096, 20))

    def cvar(x):  # the worst 10 % of 1 − R on common draws, by PyMoosh's cost
        costs = np.array([pp.cost(np.clip(np.asarray(x) + e, 0, None)) for e in errors[:1024 if quick else 4096]])
        return float(np.sort(costs)[-len(costs) // 10:].mean())

    for s in seeds[:2]:
        fab = peers.run_fabtwin_robust(seed=s)
        o = design.optimise(prob, seed=s, time_limit=20)
        row = {"problem": "robust_bragg20", "seed": s, "fabtwin": {"seconds": fab["seconds"], "cvar": cvar(fab["x"])},
               "ours": {"seconds": o.seconds, "cvar": cvar(o.thicknesses)},
               "quarter_wave": {"cvar": cvar(peers.quarter_wave(pp))}}
        log(f"robust seed {s}: CVaR10% of 1-R: fabtwin {row['fabtwin']['cvar']:.6f} ({fab['seconds']:.1f} s), ours "
            f"{row['ours']['cvar']:.6f} ({o.seconds:.1f} s), quarter-wave {row['quarter_wave']['cvar']:.6f}")
        rows.append(row)
    return rows


def bench_forward(seeds, quick, log):
    g = np.random.default_rng(0)
    B, L, W = (200 if quick else 1000), 20, 50
    idx = [1.0] + [1.8, 1.4] * (L // 2) + [1.52]
    D = g.uniform(20, 200, (B, L))
    wl = np.linspace(400, 800, W)
    ref = peers.forward_tmm(idx, D[:5], wl)
    n = torch.tensor(idx, dtype=torch.complex128)
    lam = torch.tensor(wl, dtype=torch.float64)
    import torchirid

    def ours_fn():
        with torch.inference_mode():
            return torchirid.multilayer(lam, 1.0, n, torch.tensor(D)[:, None, :], polarization="s")[0].numpy()

    fns = {"torchirid": ours_fn,
           "difftmm (float64)": lambda: peers.forward_difftmm(idx, D, wl, precision="float64"),
           "cuda-thinfilm (NumPy)": lambda: peers.forward_cuda_thinfilm(idx, D, wl),
           "PyMoosh (vectorised)": lambda: peers.forward_pymoosh(idx, D[:50 if quick else 200], wl)}
    rows = []
    times = {k: [] for k in fns}
    errs = {}
    for r in range(3 if quick else 5):
        for k, f in fns.items():
            t0 = time.perf_counter()
            out = f()
            times[k].append(time.perf_counter() - t0)
            errs[k] = float(np.abs(np.asarray(out)[:5] - ref).max())
    for k in fns:
        stacks = (50 if quick else 200) if "PyMoosh" in k else B
        rows.append({"problem": "forward", "code": k, "seconds_per_stack": med(times[k]) / stacks,
                     "max_abs_error_vs_tmm": errs[k]})
        log(f"forward {k}: {1e6 * med(times[k]) / stacks:.1f} µs per stack of {L} layers × {W} λ, |R − tmm| ≤ "
            f"{errs[k]:.1e}")
    return rows


def bench_needle(seeds, quick, log):
    """Needle optimisation on chirped(20) (broadband: inserted layers pay off): cuda-thinfilm's
    ``needle_optimization`` (5 insertions from a seeded random start) against torchirid's
    ``method="needle"`` (up to 30 layers, from the middle of the bounds), both scored by PyMoosh on
    the stacks they return (``cost_stack``)."""
    pp = peers.chirped(20)
    prob = to_problem(pp, max_layers=30)
    rows = []
    for s in seeds[:3]:
        c = peers.run_cuda_thinfilm(pp, 5, s, method="needle")
        d = design.optimise(prob, method="needle", seed=s)
        idx = [complex(m) if isinstance(m, complex) else float(m) for m in d.materials]
        cost = pp.cost_stack(idx, d.thicknesses)
        row = {"problem": "needle_chirped20", "seed": s,
               "cuda_thinfilm_needle": {"cost": c["cost"], "seconds": c["seconds"], "layers": len(c["x"])},
               "ours": {"cost": cost, "seconds": d.seconds, "layers": len(d.thicknesses), "history": d.history}}
        log(f"needle chirped20 seed {s}: cuda-thinfilm {c['cost']:.5f} ({len(c['x'])} layers, {c['seconds']:.1f} s) "
            f"| ours {cost:.5f} ({len(d.thicknesses)} layers, {d.seconds:.1f} s)")
        rows.append(row)
    return rows


BENCHES = {"bragg": bench_bragg, "chirped": bench_chirped, "pv": bench_pv, "colour": bench_colour,
           "tolerance": bench_tolerance, "needle": bench_needle, "robust": bench_robust, "forward": bench_forward}


def _other_peers(name: str, rs) -> list[str]:
    """Table rows of the peers run beside QODE (median cost [range], median seconds)."""
    out = []
    for k in ("nevergrad_TwoPointsDE", "cuda_thinfilm_de", "difftmm_adam"):
        xs = [r[k] for r in rs if k in r]
        if xs:
            out.append(f"| {name} | {k} | {med([x['cost'] for x in xs]):.6g} [{spread([x['cost'] for x in xs])}] "
                       f"| {med([x['seconds'] for x in xs]):.2f} | | | |")
    return out


def report(rows) -> str:
    lines = [("| problem | peer (same run) | peer cost, median [range] | peer s | torchirid cost | torchirid s | "
              "time ratio (median [range]) |"), "|---|---|---|---|---|---|---|"]
    by = {}
    for r in rows:
        by.setdefault(r["problem"], []).append(r)
    for name, rs in by.items():
        if name.startswith("bragg"):
            q = [r["qode"] for r in rs]
            o = [r["ours"] for r in rs]
            og = [r["ours_goal"] for r in rs]
            ratio = [a["seconds"] / b["seconds_to_target"] for a, b in zip(o, q) if b["seconds_to_target"]]
            ratio_g = [a["seconds"] / b["seconds_to_target"] for a, b in zip(og, q) if b["seconds_to_target"]]
            lines.append(f"| {name} | PyMoosh QODE, 20 000 evals; time to the optimum (1e-3) | "
                         f"{med([x['cost'] for x in q]):.9g} [{spread([x['cost'] for x in q])}] | "
                         f"{med([x['seconds_to_target'] for x in q]):.2f} to target | "
                         f"{med([x['cost'] for x in o]):.9g} [{spread([x['cost'] for x in o])}] | "
                         f"{med([x['seconds'] for x in o]):.3f} (goal: {med([x['seconds'] for x in og]):.3f}) | "
                         f"{med(ratio):.3f} [{spread(ratio)}]; goal {med(ratio_g):.3f} [{spread(ratio_g)}] |")
            lines += _other_peers(name, rs)
        elif name.startswith("chirped"):
            q = [r["qode"] for r in rs]
            o = [r["ours"] for r in rs]
            ratio = [a["seconds"] / b["seconds"] for a, b in zip(o, q)]
            lines.append(f"| {name} | PyMoosh QODE, 20 000 evals (PyMoosh spectrum) | "
                         f"{med([x['cost_pymoosh'] for x in q]):.6f} [{spread([x['cost_pymoosh'] for x in q])}] | "
                         f"{med([x['seconds'] for x in q]):.1f} | {med([x['cost'] for x in o]):.6f} "
                         f"[{spread([x['cost'] for x in o])}] | {med([x['seconds'] for x in o]):.2f} | "
                         f"{med(ratio):.3f} |")
            lines += _other_peers(name, rs)
        elif name.startswith("needle"):
            c = [r["cuda_thinfilm_needle"] for r in rs]
            o = [r["ours"] for r in rs]
            lines.append(f"| {name} | cuda-thinfilm needle (5 insertions) | {med([x['cost'] for x in c]):.5f} "
                         f"({med([x['layers'] for x in c]):.0f} layers) | {med([x['seconds'] for x in c]):.1f} | "
                         f"{med([x['cost'] for x in o]):.5f} ({med([x['layers'] for x in o]):.0f} layers) | "
                         f"{med([x['seconds'] for x in o]):.1f} | |")
        elif name.startswith("pv"):
            o = [r["ours"] for r in rs]
            for k, label in (("qode", "PyMoosh QODE, 150 evals"), ("cuda_thinfilm_de", "cuda-thinfilm DE, 3000"),
                             ("difftmm_adam", "difftmm Adam 333 × 8")):
                xs = [r[k] for r in rs if k in r]
                if xs:
                    lines.append(f"| {name} | {label} | {med([x['cost'] for x in xs]):.5f} | "
                                 f"{med([x['seconds'] for x in xs]):.1f} | {med([x['cost'] for x in o]):.5f} | "
                                 f"{med([x['seconds'] for x in o]):.1f} | |")
    return "\n".join(lines)


def figure(rows, path: Path) -> None:
    """Best merit (by the peer's cost where the peer scores it) against wall time, every seed, one
    panel per problem: torchirid and PyMoosh's QODE (and the other peers' final points)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in ("bragg10", "bragg20", "bragg40", "chirped20", "chirped40", "chirped60", "pv10", "pv20",
                         "colour6") if any(r["problem"] == n for r in rows)]
    cols = 3
    fig, axes = plt.subplots((len(names) + cols - 1) // cols, cols, figsize=(13, 3.4 * ((len(names) + 2) // 3)),
                             squeeze=False)
    marks = {"nevergrad_TwoPointsDE": ("s", "C2", "nevergrad TwoPointsDE"),
             "cuda_thinfilm_de": ("^", "C3", "cuda-thinfilm DE"), "difftmm_adam": ("v", "C4", "difftmm + Adam")}
    for ax, name in zip(axes.flat, names):
        rs = [r for r in rows if r["problem"] == name]
        labelled = set()
        for r in rs:
            for who, colour, label in (("qode", "0.55", "PyMoosh QODE"), ("ours", "C0", "torchirid")):
                src = r.get(who) if name != "colour6" else (r if who == "ours" else None)
                if not src or not src.get("history"):
                    continue
                h = np.array(src["history"], dtype=float)
                ax.step(h[:, 0], h[:, 2], where="post", color=colour, lw=1,
                        label=None if label in labelled else label)
                labelled.add(label)
            for k, (m, colour, label) in marks.items():
                if k in r:
                    ax.plot(r[k]["seconds"], r[k]["cost"], m, color=colour, ms=5,
                            label=None if label in labelled else label)
                    labelled.add(label)
        if name.startswith("bragg"):
            ax.axhline(peers.BRAGG_OPTIMA[int(name[5:])], color="k", ls=":", lw=0.8, label="quarter-wave optimum")
        ax.set(xscale="log", yscale="log", title=name, xlabel="wall time (s)",
               ylabel="ΔE2000 merit" if name == "colour6" else "best cost")
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.remove()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--only", default=",".join(BENCHES))
    ap.add_argument("--quick", action="store_true", help="fewer problems, peers and draws")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/design"))
    ap.add_argument("--report-only", action="store_true", help="rewrite the table and figure from OUT.json")
    args = ap.parse_args(argv)
    out = Path(args.out)
    if args.report_only:
        allrows = json.loads(out.with_suffix(".json").read_text())
        table = report(allrows)
        out.with_suffix(".md").write_text(table + "\n")
        print(table)
        figure(allrows, ROOT / "docs/figures/design_merit_time.png")
        return
    torch.set_num_threads(1)
    seeds = list(range(args.seeds))
    rows = []

    def log(msg):
        print(msg, flush=True)

    for name in args.only.split(","):
        t0 = time.perf_counter()
        rows += BENCHES[name](seeds, args.quick, log)
        log(f"[{name}: {time.perf_counter() - t0:.0f} s]")
    out.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(out.with_suffix(".json").read_text()) if out.with_suffix(".json").exists() else []
    keep = [r for r in old if r["problem"] not in {x["problem"] for x in rows}]
    allrows = keep + rows
    out.with_suffix(".json").write_text(json.dumps(allrows, indent=1, default=float))
    table = report(allrows)
    out.with_suffix(".md").write_text(table + "\n")
    print(table)
    figure(allrows, ROOT / "docs/figures/design_merit_time.png")


if __name__ == "__main__":
    main()
