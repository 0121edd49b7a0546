#!/usr/bin/env python
"""How many Fourier terms the fitted thin-film IBL colour needs: ΔE2000 against the ground truth.

``torchirid.ibl.thin_film_xyz_fitted`` (the light-mixture table + Kneiphof's eq. 29 per
component) with M = ``terms`` Fourier terms against ``torchirid.ibl.thin_film_xyz_uniform``
(the converged uniform-light reference: lobe quadrature, binned cos θ1, spectral Airy
reflectance), on a grid of dielectric and conductor films:

* θo ∈ {0, 20, 40, 55, 65, 70, 75, 80, 85}°, α ∈ {0.01, 0.03, 0.056, 0.1, 0.2, 0.4, 0.7, 1.0};
* film η₂ ∈ {1.33, 1.5, 2.0}, d ∈ {50, 100, 171, 250, 400, 600, 800, 1000} nm;
* bases: dielectric 1.0 (a free film), 1.5, 2.5; conductor 1.5 + 2i, 0.2 + 3i, 2 + 0.5i;

air outside, CIE 1931 2°, D65, unpolarized, ``sensitivity="exact"`` (the default) and, for the
time column, ``"lut"``. Prints a markdown table (max / p95 / median ΔE2000 per base class and
terms, and a rough time per colour: one run, µs per colour over the whole grid, the Ŝ table
built beforehand) and the issue-21 case (base 1.5 + 2i, d = 171 nm, θo = 70°, α = 0.056).
With ``--masking height_correlated`` both the table and the reference use the Smith-joint G,
and it also prints how far that reference moves from the separable one.

    PYTHONPATH=src python benchmarks/fitted_terms_error.py [--terms 2 3 4 6] [--masking height_correlated]
    PYTHONPATH=src python benchmarks/fitted_terms_error.py --quick      # a coarser grid, ~20 s

Takes ≈ 4–5 min on one core (exact Ŝ ≈ 1.2 ms per term and colour; the reference: 144 films ×
2049 cos θ1 nodes × 471 λ).
"""

from __future__ import annotations

import argparse
import math
import time

import torch

from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.ibl import thin_film_xyz_fitted, thin_film_xyz_uniform

F64 = torch.float64
THETA_DEG = (0.0, 20.0, 40.0, 55.0, 65.0, 70.0, 75.0, 80.0, 85.0)
ALPHA = (0.01, 0.03, 0.056, 0.1, 0.2, 0.4, 0.7, 1.0)
N_FILM = (1.33, 1.5, 2.0)
THICKNESS = (50.0, 100.0, 171.0, 250.0, 400.0, 600.0, 800.0, 1000.0)
DIELECTRIC = (1.0, 1.5, 2.5)
CONDUCTOR = (complex(1.5, 2.0), complex(0.2, 3.0), complex(2.0, 0.5))
QUICK = dict(theta=(0.0, 40.0, 70.0, 85.0), alpha=(0.03, 0.056, 0.2, 0.7), n_film=(1.33, 2.0),
             thickness=(100.0, 171.0, 600.0), dielectric=(1.0, 1.5), conductor=(complex(1.5, 2.0), complex(0.2, 3.0)))


def _grid(theta, alpha, n_film, thickness, bases):
    """Geometry (G,) × films (F,): cos θo, α of shape (G, 1); η₂, d, base of shape (1, F)."""
    th = torch.deg2rad(torch.tensor(theta, dtype=F64))
    c, a = torch.meshgrid(torch.cos(th), torch.tensor(alpha, dtype=F64), indexing="ij")
    c = c.reshape(-1, 1).clamp(max=1.0)
    a = a.reshape(-1, 1)
    films = [(nf, d, b) for nf in n_film for d in thickness for b in bases]
    nf = torch.tensor([f[0] for f in films], dtype=F64)[None]
    d = torch.tensor([f[1] for f in films], dtype=F64)[None]
    ns = torch.tensor([complex(f[2]) for f in films], dtype=torch.complex128)[None]
    return c, a, nf, d, ns


def _fitted(c, a, nf, d, ns, terms, masking, sensitivity):
    """thin_film_xyz_fitted over (G, F), chunked over G (the exact Ŝ holds (·, 3760) per term and component)."""
    kw = {"masking": masking}
    # ≤ 2²⁴ (≈ 128 MB) per (colours × components × terms × 3760 Ŝ nodes) intermediate of the exact Ŝ
    chunk = max(1, (1 << 24) // (nf.shape[1] * 5 * max(terms, 1) * 3760))
    rows = [thin_film_xyz_fitted(c[s:s + chunk], a[s:s + chunk], nf, d, ns, terms=terms,
                                 sensitivity=sensitivity, **kw) for s in range(0, c.shape[0], chunk)]
    return torch.cat(rows)


def _stats(de):
    de = de.reshape(-1)
    return float(de.max()), float(torch.quantile(de, 0.95)), float(de.median())


def run(theta, alpha, n_film, thickness, dielectric, conductor, terms, masking):
    out = []
    kw = {"masking": masking}
    classes = (("dielectric", dielectric), ("conductor", conductor))
    per_class = {}
    shift = []
    t_ref = 0.0
    for name, bases in classes:
        c, a, nf, d, ns = _grid(theta, alpha, n_film, thickness, bases)
        t = time.perf_counter()
        ref = xyz_to_lab(thin_film_xyz_uniform(c, a, nf, d, ns, **kw))
        t_ref += time.perf_counter() - t
        per_class[name] = (c, a, nf, d, ns, ref)
        if masking != "separable":  # how far the reference moves from the separable G's
            shift.append(delta_e_2000(ref, xyz_to_lab(thin_film_xyz_uniform(c, a, nf, d, ns))).reshape(-1))
    n_colours = sum(v[0].shape[0] * v[2].shape[1] for v in per_class.values())
    out.append(f"grid: {len(theta)} θo × {len(alpha)} α × {len(n_film)} η₂ × {len(thickness)} d × "
               f"({len(dielectric)} dielectric + {len(conductor)} conductor bases) = {n_colours} colours; "
               f"masking = {masking}; reference {1e3 * t_ref / n_colours:.2f} ms/colour")
    if shift:
        out.append("reference colour, %s vs separable G: ΔE2000 max / p95 / median %.2f / %.2f / %.3f"
                   % ((masking,) + _stats(torch.cat(shift))))
    out.append("")
    out.append("| terms | dielectric max / p95 / median | conductor max / p95 / median | all max / p95 / median "
               "| µs/colour (exact Ŝ) | µs/colour (Ŝ table) |")
    out.append("|---|---|---|---|---|---|")
    thin_film_xyz_fitted(0.5, 0.1, 1.33, 100.0, 1.5, sensitivity="lut", **kw)  # build the Ŝ table first
    for m in terms:
        des = {}
        times = {}
        for sens in ("exact", "lut"):
            t = time.perf_counter()
            got = {name: _fitted(*v[:5], m, masking, sens) for name, v in per_class.items()}
            times[sens] = (time.perf_counter() - t) / n_colours * 1e6
            if sens == "exact":
                des = {name: delta_e_2000(xyz_to_lab(got[name]), per_class[name][5]) for name in got}
        cells = []
        for name in ("dielectric", "conductor"):
            cells.append("%.2f / %.2f / %.3f" % _stats(des[name]))
        cells.append("%.2f / %.2f / %.3f" % _stats(torch.cat([x.reshape(-1) for x in des.values()])))
        out.append(f"| {m} | " + " | ".join(cells) + f" | {times['exact']:.0f} | {times['lut']:.0f} |")
        worst = {}
        for name in ("dielectric", "conductor"):
            c, a, nf, d, ns, _ = per_class[name]
            i = int(des[name].argmax())
            g, f = divmod(i, nf.shape[1])
            worst[name] = (f"θo {math.degrees(math.acos(float(c[g, 0]))):.0f}°, α {float(a[g, 0]):g}, "
                           f"η₂ {float(nf[0, f]):g}, d {float(d[0, f]):g} nm, base {complex(ns[0, f])}")
        out.append(f"|   | worst: {worst['dielectric']} | worst: {worst['conductor']} | | | |")
    # the case quoted in issue 21
    c = torch.tensor(math.cos(math.radians(70.0)), dtype=F64)
    out.append("")
    out.append("Issue-21 case (base 1.5 + 2i, d 171 nm, θo 70°, α 0.056), ΔE2000 per η₂ and the max over "
               "η₂ = 1.2, 1.25, …, 2.5:")
    out.append("")
    out.append("| η₂ | " + " | ".join(f"terms {m}" for m in terms) + " |")
    out.append("|---|" + "---|" * len(terms))
    nf = torch.tensor([1.2, 1.33, 1.5, 1.65, 2.0], dtype=F64)
    sweep = torch.linspace(1.2, 2.5, 27, dtype=F64)
    rows = {}
    for name, n in (("rows", nf), ("sweep", sweep)):
        ref = xyz_to_lab(thin_film_xyz_uniform(c, 0.056, n, 171.0, complex(1.5, 2.0), **kw))
        rows[name] = torch.stack([delta_e_2000(xyz_to_lab(thin_film_xyz_fitted(c, 0.056, n, 171.0, complex(1.5, 2.0),
                                                                                terms=m, **kw)), ref)
                                  for m in terms], -1)
    for i, n in enumerate(nf.tolist()):
        out.append(f"| {n:g} | " + " | ".join(f"{x:.2f}" for x in rows["rows"][i].tolist()) + " |")
    out.append("| max 1.2–2.5 | " + " | ".join(f"{x:.2f}" for x in rows["sweep"].amax(0).tolist()) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--terms", type=int, nargs="+", default=[2, 3, 4, 6])
    ap.add_argument("--masking", default="separable", choices=("separable", "height_correlated"),
                    help="the G of the table and of the reference (default: separable)")
    ap.add_argument("--quick", action="store_true", help="a coarser grid (~20 s)")
    args = ap.parse_args(argv)
    torch.set_num_threads(max(1, torch.get_num_threads()))
    g = QUICK if args.quick else dict(theta=THETA_DEG, alpha=ALPHA, n_film=N_FILM, thickness=THICKNESS,
                                      dielectric=DIELECTRIC, conductor=CONDUCTOR)
    t = time.perf_counter()
    print(run(**g, terms=args.terms, masking=args.masking))
    print(f"\n({time.perf_counter() - t:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
