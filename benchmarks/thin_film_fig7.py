#!/usr/bin/env python
"""Kneiphof et al. 2019 Fig. 7, measured: thin-film colour of a rough surface under uniform light.

Both panels — θo × √α at d = 600 nm and θo × d ∈ [0, 1000] nm at α = 0.25 — for the original
(Belcour–Barla at the ideal reflection direction), Kneiphof's eq. 20–29 with the ground-truth
light moments, eq. 29 with the ground-truth μ_D, σ²_D, and the fitted light-mixture table,
against the converged reference (torchirid.ibl.thin_film_xyz_uniform). Film η₂ = 1.3 on a
base 2 + 0.5i (Kneiphof's Fig. 2 material), air, CIE 1931 2°, D65, M = 2.

    PYTHONPATH=src python benchmarks/thin_film_fig7.py [--resolution 64] [--repeats 3] [--write-docs]
    PYTHONPATH=src python benchmarks/thin_film_fig7.py --sensitivity-accuracy [--write-docs]   # ≈ 1 min

Prints a markdown table (mean / p95 / max ΔE2000 per method and panel, also for α ≥ 0.25, and
µs per colour, medians of interleaved repeats); writes docs/figures/thin_film_fig7.png and,
with --write-docs, the "thin-film-ibl" section of benchmarks/results/thin_film_fig7.md
(docs/performance.md is maintained by hand from it).

``--sensitivity-accuracy`` instead measures how the Ŝ tables interpolate (max |Ŝ_table − Ŝ_exact|):
the 1-D Ŝ(D) in (magnitude, unwrapped phase) vs (real, imag) vs demodulated (real, imag) at
several D steps, and layouts of Kneiphof's 2-D Ŝ(μ, σ²); with --write-docs it rewrites only its
own subsection (between the thin-film-ibl-sensitivity markers) of the thin-film-ibl section.
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import time
from pathlib import Path

import torch

from torchirid.ibl import thin_film_xyz_fitted, thin_film_xyz_filtered, thin_film_xyz_fourier
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.ibl import uniform_light_moments
from torchirid.ibl.fitted import shipped_light_mixture_lut
from torchirid.ibl.sensitivity import shipped_prefiltered_sensitivity_lut
from torchirid.app.figures.thin_film_ibl import THIN_FILM_IBL_METHODS, save_thin_film_ibl_png, thin_film_ibl_comparison

ROOT = Path(__file__).resolve().parents[1]
MARK = "thin-film-ibl"
SUBMARK = "thin-film-ibl-sensitivity"


def _sensitivity_accuracy() -> str:
    """Markdown: interpolation error of the 1-D and 2-D Ŝ tables against the exact quadrature."""
    import math

    import numpy as np

    from torchirid.ibl.sensitivity import (
        _carriers,
        prefiltered_sensitivity_lut,
        fourier_sensitivity_exact,
        prefiltered_fourier_sensitivity,
        lookup_prefiltered_sensitivity,
    )
    from torchirid.lut import LUT

    f64 = torch.float64
    out = ["1-D Ŝ(D), CIE 1931 2° / D65: max over D ∈ [0, 20 µm] (1 nm grid) and channels of |Ŝ_interp − Ŝ|, "
           "linear interpolation of each representation on nodes every `step` nm:", "",
           "| step (nm) | magnitude + unwrapped phase | real + imag | demodulated real + imag (carrier 1/ν̄_j) |",
           "|---|---|---|---|"]
    Dq = torch.arange(0.0, 20000.0 + 0.5, 1.0, dtype=f64)
    exact = fourier_sensitivity_exact(Dq)
    nu0 = _carriers("CIE 1931 2", "D65", f64, torch.device("cpu"))
    rot = lambda D, sign: torch.polar(torch.ones_like(nu0), sign * 2 * math.pi * D[:, None] * nu0)  # noqa: E731
    for step in (2, 4, 8, 16):
        nodes = Dq[::step]
        s = exact[::step]
        ax = {"D": nodes}
        mp = np.stack([s.abs().numpy(), np.unwrap(np.angle(s.numpy()), axis=0)], -1)
        v = LUT(torch.from_numpy(mp), ax, builder="bench")(D=Dq)
        e_mp = (torch.polar(v[..., 0], v[..., 1]) - exact).abs().max().item()
        v = LUT(torch.stack([s.real, s.imag], -1), ax, builder="bench")(D=Dq)
        e_ri = (torch.complex(v[..., 0], v[..., 1]) - exact).abs().max().item()
        sd = s * rot(nodes, 1.0)
        v = LUT(torch.stack([sd.real, sd.imag], -1), ax, builder="bench")(D=Dq)
        e_dm = (torch.complex(v[..., 0], v[..., 1]) * rot(Dq, -1.0) - exact).abs().max().item()
        out.append(f"| {step} | {e_mp:.2g} | {e_ri:.2g} | {e_dm:.2g} |")
    # 2-D: 30,000 random (μ, σ), a third with σ < 50 nm, a third < 300 nm
    g = torch.Generator().manual_seed(1)
    n = 30000
    mu = torch.rand(n, generator=g, dtype=f64) * 20000.0
    sig = torch.cat([torch.rand(n // 3, generator=g, dtype=f64) * 50.0, torch.rand(n // 3, generator=g, dtype=f64) * 300.0,
                     torch.rand(n - 2 * (n // 3), generator=g, dtype=f64) * 1000.0])
    ref = prefiltered_fourier_sensitivity(mu, sig * sig)
    mug = torch.arange(0.0, 20000.0 + 5.0, 10.0, dtype=f64)
    bands = ((0, 25), (25, 100), (100, 300), (300, 1000.01))

    def row(name, err):
        parts = [f"{err[(sig >= lo) & (sig < hi)].max().item():.2g}" for lo, hi in bands]
        i = int(err.argmax())
        return (f"| {name} | {err.max().item():.2g} | " + " | ".join(parts)
                + f" | μ = {mu[i].item():.0f}, σ = {sig[i].item():.0f} |")

    def legacy(var, demod):  # σ uniform, 41 nodes; axis σ or σ²; (mag, unwrapped phase) or demodulated (re, im)
        sn = torch.linspace(0.0, 1000.0, 41, dtype=f64)
        s = prefiltered_fourier_sensitivity(mug[:, None], sn[None] ** 2)
        if demod:
            s = s * torch.polar(torch.ones_like(nu0), 2 * math.pi * nu0 * mug[:, None, None])
            vals = torch.stack([s.real, s.imag], -1)
        else:
            vals = torch.from_numpy(np.stack([s.abs().numpy(), np.unwrap(np.angle(s.numpy()), axis=0)], -1))
        lut = LUT(vals, {"mu": mug, "s": sn if var == "sigma" else sn * sn}, builder="bench")
        v = lut(mu=mu, s=sig if var == "sigma" else sig * sig)
        if demod:
            got = torch.complex(v[..., 0], v[..., 1]) * torch.polar(torch.ones_like(nu0), -2 * math.pi * nu0 * mu[:, None])
        else:
            got = torch.polar(v[..., 0], v[..., 1])
        return (got - ref).abs().amax(-1)

    out += ["", "Kneiphof's 2-D Ŝ(μ, σ²) (eq. 18), μ every 10 nm to 20 µm, bilinear: max |Ŝ_lut − Ŝ| over 30,000 random "
            "(μ, σ) (μ ∈ [0, 20 µm]; σ ∈ [0, 50), [0, 300), [0, 1000] nm, a third each), by σ band:", "",
            "| layout | max | σ < 25 | 25–100 | 100–300 | 300–1000 | worst at |", "|---|---|---|---|---|---|---|"]
    out.append(row("41 σ nodes uniform, magnitude + unwrapped phase (before)", legacy("sigma", False)))
    out.append(row("41 nodes uniform in σ, axis σ², magnitude + phase", legacy("sigma2", False)))
    out.append(row("41 σ nodes uniform, demodulated real + imag", legacy("sigma", True)))
    for k in (41, 61):
        lut = prefiltered_sensitivity_lut(sigma_nodes=k)
        err = (lookup_prefiltered_sensitivity(mu, sig * sig, lut=lut) - ref).abs().amax(-1)
        tag = " (shipped default)" if k == 41 else ""
        out.append(row(f"{k} nodes uniform in w = 1 − exp(−2π²σ²/700²), demodulated real + imag{tag}", err))
    out += ["", "Why: linear in σ across what is a Gaussian damping exp(−2π²σ²ν²) errs by ≈ h²·2π²ν²/4 in the first "
            "cells (1.5e-2 at h = 25 nm); and a per-σ phase unwrapped along μ can jump by 2π between neighbouring σ "
            "columns where a channel's |Ŝ| passes near 0 (Y between σ = 125 and 150 nm at μ ≈ 4.15 µm, |Ŝ_Y| ≈ 0.005–0.01), "
            "so the bilinear phase is wrong there. Demodulating by each channel's centroid wavenumber ν̄_j leaves a "
            "slowly varying envelope stored as (real, imag), with no branch cut; the w axis makes the damping close "
            "to linear and spreads the nodes where Ŝ still changes."]
    return "\n".join(out)


def _write_subsection(text: str) -> Path:
    perf = ROOT / "benchmarks/results/thin_film_fig7.md"
    doc = perf.read_text() if perf.exists() else ""
    start, end = f"<!-- {MARK}:start -->", f"<!-- {MARK}:end -->"
    sub_start, sub_end = f"<!-- {SUBMARK}:start -->", f"<!-- {SUBMARK}:end -->"
    body = f"{sub_start}\n### Ŝ tables: interpolation error\n\n{text}\n{sub_end}"
    if sub_start in doc:
        doc = re.sub(re.escape(sub_start) + ".*?" + re.escape(sub_end), lambda m: body, doc, flags=re.S)
    elif end in doc:
        doc = doc.replace(end, "\n" + body + "\n" + end)
    else:
        doc = doc.rstrip("\n") + f"\n\n{start}\n{body}\n{end}\n"
    perf.write_text(doc)
    return perf


def _timings(repeats: int, n: int = 4096) -> dict:
    """µs per colour of the three run-time methods on n random (θo, α, d) colours (moments given)."""
    torch.manual_seed(0)
    f64 = torch.float64
    c = torch.rand(n, dtype=f64) * 0.99 + 0.01
    a = torch.rand(n, dtype=f64)
    d = torch.rand(n, dtype=f64) * 1000.0
    wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1)
    mu = wo * torch.tensor([-1.0, 1.0, 1.0], dtype=f64) * 0.95
    cov = 1e-2 * torch.eye(3, dtype=f64).expand(n, 3, 3)
    shipped_light_mixture_lut(dtype=f64)  # load once
    fns = {
        "original": lambda: thin_film_xyz_fourier(c, 1.3, d, complex(2, 0.5), terms=2, sensitivity="exact"),
        "original (Ŝ LUT)": lambda: thin_film_xyz_fourier(c, 1.3, d, complex(2, 0.5), terms=2),
        "kneiphof": lambda: thin_film_xyz_filtered(wo, mu, cov, 1.3, d, complex(2, 0.5), terms=2, sensitivity="exact"),
        "kneiphof (Ŝ 2-D LUT)": lambda: thin_film_xyz_filtered(wo, mu, cov, 1.3, d, complex(2, 0.5), terms=2,
                                                              sensitivity="lut"),
        "fitted": lambda: thin_film_xyz_fitted(c, a, 1.3, d, complex(2, 0.5), terms=2, sensitivity="exact"),
        "fitted (Ŝ 2-D LUT)": lambda: thin_film_xyz_fitted(c, a, 1.3, d, complex(2, 0.5), terms=2, sensitivity="lut"),
    }
    shipped_prefiltered_sensitivity_lut(dtype=f64)  # built once (≈ 4 s), not timed
    samples = {k: [] for k in fns}
    for _ in range(repeats):
        for k, f in fns.items():
            t0 = time.perf_counter()
            f()
            samples[k].append((time.perf_counter() - t0) / n * 1e6)
    return {k: statistics.median(v) for k, v in samples.items()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--resolution", type=int, default=64)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--figure", type=Path, default=ROOT / "docs/figures/thin_film_fig7.png")
    p.add_argument("--write-docs", action="store_true")
    p.add_argument("--sensitivity-accuracy", action="store_true",
                   help="only measure the interpolation error of the Ŝ tables (≈ 1 min)")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    if args.sensitivity_accuracy:
        cmd = "PYTHONPATH=src python benchmarks/thin_film_fig7.py --sensitivity-accuracy"
        text = f"`{cmd}` (float64 CPU)\n\n" + _sensitivity_accuracy()
        print(text)
        if args.write_docs:
            print(f"updated {_write_subsection(text)}")
        return 0
    panels = [thin_film_ibl_comparison(k, resolution=args.resolution) for k in ("roughness", "thickness")]
    save_thin_film_ibl_png(panels, args.figure)
    times = _timings(args.repeats)
    cmd = "PYTHONPATH=src python benchmarks/thin_film_fig7.py " + " ".join(argv if argv is not None else sys.argv[1:])
    out = [f"`{cmd.strip()}` — {args.resolution} × {args.resolution} cell centres per panel, η₂ = 1.3 on "
           "2 + 0.5i, air, CIE 1931 2°, D65, M = 2, float64 CPU, "
           f"{args.threads} threads. Reference: thin_film_xyz_uniform (lobe quadrature 64 × 128, "
           "2048 cos θ1 bins, 1 nm spectra; converged to ΔE2000 < 0.005). ΔE2000 of the reflectance term "
           "(the albedo A(θo, α) is common to all methods). The fitted table (`ibl.shipped_light_mixture_lut`, "
           "built by `luts/build_light_mixture.py`) holds 48 θo × 48 √α nodes × 5 Gaussians × (mass, mean, "
           "variance of cos θ₁) = 34,560 float32 (137 KiB), independent of the film: the same table serves every "
           "d, η₂ and base; the panels' cells fall between its nodes.", "",
           "| panel | method | ΔE2000 mean | p95 | max | mean for α ≥ 0.25 |", "|---|---|---|---|---|---|"]
    labels = dict(THIN_FILM_IBL_METHODS)
    for pan in panels:
        stats = pan.stats()
        rough = pan.stats(pan.alpha >= 0.25) if pan.panel == "roughness" else stats
        name = "θo × √α (d = 600 nm)" if pan.panel == "roughness" else "θo × d (α = 0.25)"
        for k, _ in THIN_FILM_IBL_METHODS:
            s = stats[k]
            out.append(f"| {name} | {labels[k]} | {s['mean']:.2f} | {s['p95']:.2f} | {s['max']:.2f} | "
                       f"{rough[k]['mean']:.2f} |")
    # the shader path: Ŝ(μ, σ²) from Kneiphof's 2-D table instead of the exact quadrature
    out += ["", "With Ŝ(μ, σ²) read from Kneiphof's 2-D table (`sensitivity=\"lut\"`, μ step 10 nm, 41 nodes "
            "in w = 1 − exp(−2π²σ²/700²) to σ = 1000 nm, demodulated real + imag; max |ΔŜ| 4.7e-4), as a shader would:", "",
            "| panel | method | ΔE2000 mean | p95 | max |", "|---|---|---|---|---|"]
    for pan in panels:
        c = torch.as_tensor(pan.cos_theta)[:, None].expand(pan.alpha.shape)
        a = torch.as_tensor(pan.alpha)
        d = torch.as_tensor(pan.thickness_nm)
        _, mu, cov = uniform_light_moments(c, a)
        wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1)
        ref = xyz_to_lab(torch.as_tensor(pan.xyz["reference"]))
        name = "θo × √α (d = 600 nm)" if pan.panel == "roughness" else "θo × d (α = 0.25)"
        for label, x in (("Kneiphof (GT μ_ωi, Σ_ωi), Ŝ LUT",
                          thin_film_xyz_filtered(wo, mu, cov, 1.3, d, complex(2, 0.5), terms=2, sensitivity="lut")),
                         ("fitted mixture table, Ŝ LUT",
                          thin_film_xyz_fitted(c, a, 1.3, d, complex(2, 0.5), terms=2, sensitivity="lut"))):
            de = delta_e_2000(xyz_to_lab(x), ref)
            out.append(f"| {name} | {label} | {de.mean():.2f} | {de.flatten().quantile(0.95):.2f} | {de.max():.2f} |")
    out += ["", "| method (4096 random colours, moments given) | µs / colour |", "|---|---|"]
    out += [f"| {k} | {v:.1f} |" for k, v in times.items()]
    out += ["", "Cost model: each colour needs M Ŝ(μ, σ²) evaluations for the original and Kneiphof, K·M for "
            "the fitted table (K = 5 components, M = 2): in a shader, 10 bilinear fetches of the 2-D Ŝ "
            "texture and 15 of the mixture table instead of 2 (+ 9 moment channels). On this CPU the exact "
            "Ŝ quadrature (≈ 3,760 spectral nodes) dominates every time above; the µs were taken on the "
            "shared 2-core machine and are comparable only within one run."]
    text = "\n".join(out)
    print(text)
    if args.write_docs:
        perf = ROOT / "benchmarks/results/thin_film_fig7.md"
        doc = perf.read_text() if perf.exists() else ""
        start, end = f"<!-- {MARK}:start -->", f"<!-- {MARK}:end -->"
        sub = re.search(re.escape(f"<!-- {SUBMARK}:start -->") + ".*?" + re.escape(f"<!-- {SUBMARK}:end -->"),
                        doc, flags=re.S)
        keep = f"\n\n{sub.group(0)}" if sub else ""  # the --sensitivity-accuracy subsection survives
        body = (f"{start}\n## Thin-film colour on rough surfaces under uniform light: Kneiphof Fig. 7 "
                f"\n\n{text}\n\n![Fig. 7](../../docs/figures/thin_film_fig7.png){keep}\n{end}")
        if start in doc:
            doc = re.sub(re.escape(start) + ".*?" + re.escape(end), lambda m: body, doc, flags=re.S)
        else:
            doc = doc.rstrip("\n") + "\n\n" + body + "\n"
        perf.write_text(doc)
        print(f"updated {perf}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
