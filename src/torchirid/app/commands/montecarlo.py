"""``torchirid montecarlo``: the Monte Carlo reference BRDF of a layered Bragg structure in
independent seeded blocks — in this process, on a local Dask cluster or on a Dask scheduler —
bit-identical whatever runs the blocks (:func:`torchirid.scale.montecarlo_brdf_blocks`), printed
with its standard error beside the single-reflection BRDF (eq. 34): their difference is the
light that reflects more than once."""

from __future__ import annotations

import math

from .. import _args

NAME = "montecarlo"

__all__ = ["NAME", "add_parser", "run"]

#: ``--preset`` names of Fourneau et al. 2024 Fig. 7's structures → :func:`torchirid.presets.fourneau_fig7` names
FIG7_PRESETS = {"fig7_a": "a", "fig7_b": "b", "fig7_a_coated": "a_coated"}

#: at most this many wavelengths per exit direction in the printed table (all of them in --out)
TABLE_WAVELENGTHS = 12


def add_parser(subparsers):
    """Register ``montecarlo`` (``func=run``); returns its parser."""
    from ...presets import JEWEL_BEETLE_NAMES

    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="Monte Carlo reference BRDF of a layered Bragg structure (multiple scattering), with its standard "
             "error and the single-reflection model, in seeded blocks (Dask) → JSON/NPZ",
        description=(
            "Estimate f_r(wi, wo, λ) of a layered Bragg structure (Fourneau et al. 2024 §4.2: rough\n"
            "Bragg layers over a Lambertian base, under a smooth coating when the host index is not 1)\n"
            "by path tracing every path, multiple scattering included, split into --blocks independent\n"
            "seeded blocks of paths. For the same --seed and --blocks the estimate and its standard\n"
            "error are the same bits whatever runs the blocks: this process (default), a local Dask\n"
            "cluster (--scheduler local --workers N) or a Dask scheduler (--scheduler tcp://HOST:PORT).\n"
            "\n"
            "Prints, per exit direction and wavelength, the estimate ± its standard error (sr⁻¹) and\n"
            "the single-reflection BRDF (eq. 34, paths that reflect exactly once): their difference,\n"
            "in standard errors, is the multiply scattered light — between the layers (--layers 2),\n"
            "between a layer and a reflective base (--base-albedo 0.5), or sent back down by the\n"
            "coating (fig7_a_coated). One layer in air over a black base (a preset alone) has none:\n"
            "every path out reflects once, the estimate equals eq. 34 and its standard error is 0.\n"
            "Writes --out: .json (wavelength_nm, directions, brdf, stderr and single_reflection per\n"
            "pair and wavelength, settings) or .npz (the same arrays).\n"
            "\n"
            "Examples:\n"
            "  # Fig. 7's structure A, two layers over a diffuse base: 10-100 % above eq. 34, 7-27 SE\n"
            "  torchirid montecarlo --preset fig7_a --layers 2 --base-albedo 0.5 --incident 30 0 \\\n"
            "      --exit 0 0 --exit 45 180 --samples 16384 --out fig7a.json      # a few seconds\n"
            "  torchirid montecarlo --preset green --incident 30 0 --exit 30 180 --exit 45 180 \\\n"
            "      --samples 65536 --blocks 32 --scheduler local --workers 4 --out green.json"
        ),
    )
    p.add_argument("--preset", choices=(*JEWEL_BEETLE_NAMES, *FIG7_PRESETS), default="green",
                   help="the rough Bragg layer: a jewel-beetle cuticle of Fourneau et al. Table 3 (green, red, "
                        "purple: in air, α = 0.05) or a structure of their Fig. 7 (fig7_a: n2 = 1.5, N = 10, "
                        "d1 = d2 = 250 nm, α = 0.1; fig7_b: d1 = d2 = 494 nm, α = 0.05; fig7_a_coated: A in a "
                        "host of index 1.35 under a smooth coating) (default green)")
    p.add_argument("--layers", type=_args.count, default=1, metavar="K",
                   help="K copies of the preset's rough layer, one above the other (default 1)")
    p.add_argument("--base-albedo", type=_args.nonnegative, default=0.0, metavar="RHO",
                   help="albedo ρd in [0, 1] of the Lambertian base under the layers (default 0: black, "
                        "the beetles' absorbing base; Fig. 7's diffuse base is 0.5)")
    p.add_argument("--incident", nargs=2, type=_args.number, required=True, metavar=("THETA", "PHI"),
                   help="direction of incidence wi: polar and azimuth angles in degrees")
    p.add_argument("--exit", nargs=2, type=_args.number, action="append", required=True, metavar=("THETA", "PHI"),
                   help="an exit direction wo (degrees; repeat for several)")
    p.add_argument("--wavelengths", nargs=3, metavar=("MIN", "MAX", "COUNT"), default=["400", "700", "7"],
                   help="wavelength grid in nm (default 400 700 7)")
    p.add_argument("--samples", type=_args.count, default=8192,
                   help="paths per direction pair in all (default 8192); the standard error falls as 1/√samples")
    p.add_argument("--blocks", type=_args.count, default=16, help="independent seeded blocks (default 16)")
    p.add_argument("--seed", type=_args.whole_number(0), default=0,
                   help="seed of the whole estimate, a whole number >= 0 (default 0); another seed, another estimate "
                        "within the standard error")
    p.add_argument("--transmission", choices=("filter", "microfacet"), default="filter",
                   help="transmission through a rough layer: the F_α filter (default) or sampled microfacets "
                        "(same expectation)")
    _args.add_scheduler_options(p, "block")
    p.add_argument("--out", required=True, metavar="FILE", help="the result: .json or .npz")
    _args.add_output_options(p, figures=False)
    p.set_defaults(func=run, parser=p)
    return p


def _direction(theta: float, phi: float, option: str):
    if not 0.0 <= theta < 90.0:
        raise ValueError(f"{option} THETA must lie in [0, 90) degrees (above the surface); got {theta:g}")
    t, f = math.radians(theta), math.radians(phi)
    return [math.sin(t) * math.cos(f), math.sin(t) * math.sin(f), math.cos(t)]


def _structure(preset: str, *, layers: int = 1, base_albedo: float = 0.0):
    """The :class:`~torchirid.layered.LayeredBragg` of ``--preset``, ``--layers`` and ``--base-albedo``."""
    from ...presets import fourneau_fig7, jewel_beetle

    if not 0.0 <= base_albedo <= 1.0:
        raise ValueError(f"--base-albedo must lie in [0, 1] (the fraction of light the base reflects); "
                         f"got {base_albedo:g}")
    if preset in FIG7_PRESETS:
        return fourneau_fig7(FIG7_PRESETS[preset], layers=layers, base_albedo=base_albedo)
    return jewel_beetle(preset, layers=layers, base_albedo=base_albedo)


def _describe(s, preset: str) -> str:
    layers = len(s.layers)
    base = f"a Lambertian base ρd = {s.base_albedo:g}" if s.base_albedo > 0 else "a black base"
    host = f"under a smooth coating of index {s.n_coating:g}" if s.coated else "in air"
    return f"{preset}: {layers} rough layer{'s' if layers > 1 else ''} {host} over {base}"


def _table(lam, exits, mean, err, single) -> list[str]:
    """The printed lines: per exit direction and wavelength the estimate ± its standard error,
    the single-reflection BRDF and their difference in standard errors (at most
    ``TABLE_WAVELENGTHS`` wavelengths per direction)."""
    import torch

    W = lam.numel()
    rows = torch.linspace(0, W - 1, min(W, TABLE_WAVELENGTHS)).round().long().unique().tolist()
    lines = [(f"{'exit θ, φ (°)':>14}  {'λ (nm)':>7}  {'Monte Carlo':>11}  {'± SE':>9}  {'eq. 34':>11}  "
              f"{'MC − eq. 34':>11}  {'in SE':>6}")]
    err = _exact_zero(mean, err)
    for k, (theta, phi) in enumerate(exits):
        for j in rows:
            m, e, s = float(mean[k, j]), float(err[k, j]), float(single[k, j])
            z = f"{(m - s) / e:+6.1f}" if e > 0 else f"{'—':>6}"
            where = f"{theta:g}, {phi:g}" if j == rows[0] else ""
            lines.append(f"{where:>14}  {float(lam[j]):7.4g}  {m:11.5g}  {e:9.2g}  {s:11.5g}  {m - s:+11.4g}  {z}")
    if len(rows) < W:
        lines.append(f"({len(rows)} of {W} wavelengths shown; all of them in --out)")
    return lines


def _summary(s, lam, exits, mean, err, single) -> str:
    """One line on the multiple scattering: none possible, or the largest difference from eq. 34
    in standard errors."""
    if len(s.layers) == 1 and s.base_albedo == 0 and not s.coated:
        return ("one rough layer in air over a black base: every path out reflects exactly once, so the estimate "
                "is the single-reflection BRDF (eq. 34) exactly and its standard error is 0; add --base-albedo, "
                "--layers or a coated preset (fig7_a_coated) to see multiple scattering")
    err = _exact_zero(mean, err)
    diff = mean - single
    z = _z_scores(err, diff)
    k, j = divmod(int(z.argmax()), mean.shape[1])
    m, e, f = float(mean[k, j]), float(err[k, j]), float(single[k, j])
    rel = f"{100 * (m - f) / f:+.3g} %" if f > 0 else f"{m - f:+.3g} sr⁻¹"
    where = f"exit {exits[k][0]:g}, {exits[k][1]:g}°, {float(lam[j]):g} nm"
    if e > 0 and m - f > 3 * e:
        return (f"multiple scattering: the estimate exceeds eq. 34 by up to {(m - f) / e:.1f} standard errors "
                f"({rel} at {where})")
    return (f"no significant multiple scattering at these directions: the largest difference from eq. 34 is "
            f"{rel} ({(m - f) / e if e > 0 else 0:.1f} standard errors, {where}); more --samples resolve less")


def _exact_zero(mean, err):
    """``err`` with the rounding noise of a zero-variance estimate (the blocks' means differ in
    the last bits) set to 0: below 1e-12 of the estimate."""
    import torch

    return torch.where(err > 1e-12 * mean.abs(), err, torch.zeros_like(err))


def _z_scores(err, diff):
    """``diff / err`` where ``err > 0``, else 0 (the entries without noise are exact)."""
    import torch

    return torch.where(err > 0, diff / torch.where(err > 0, err, torch.ones_like(err)), torch.zeros_like(diff))


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Run the blocks and write the estimate. Exit status: 0; 1 (scheduler unreachable, write); 2 (bad argument)."""
    import json
    from pathlib import Path

    import numpy as np
    import torch

    from ... import _checks
    from ..._io import write_json
    from ...layered import single_reflection_brdf
    from ...scale.montecarlo import montecarlo_brdf_blocks

    lo, hi, n = _args.parse_wavelengths(args.wavelengths)
    lam = torch.linspace(lo, hi, n, dtype=torch.float64)
    _checks.check_wavelength(lam, "--wavelengths")  # nm, not metres
    wi = _direction(*args.incident, "--incident")
    wo = torch.tensor([_direction(t, f, "--exit") for t, f in args.exit], dtype=torch.float64)
    wi = torch.tensor(wi, dtype=torch.float64).expand_as(wo)
    if args.samples < 2 * args.blocks:
        raise ValueError(f"--samples must be at least 2 × --blocks ({2 * args.blocks}); got {args.samples}")
    out = Path(args.out)
    if out.suffix.lower() not in (".json", ".npz"):
        raise ValueError(f"--out must end in .json or .npz; got {args.out!r}")
    s = _structure(args.preset, layers=args.layers, base_albedo=args.base_albedo)
    bar = _args.progress_bar(f"{NAME} {args.preset}", total=args.blocks, unit="block", quiet=args.quiet)
    try:
        mean, err = montecarlo_brdf_blocks(lam, wi, wo, s,
                                           samples=args.samples, blocks=args.blocks, seed=args.seed,
                                           scheduler=args.scheduler, workers=args.workers, timeout=args.timeout,
                                           progress=_args.progress_callback(bar), transmission=args.transmission)
    except ImportError as e:
        return _args.fail(NAME, f"--scheduler needs the scale extra (dask, distributed): {e}", status=1)
    except OSError as e:
        return _args.fail(NAME, e, status=1)
    finally:
        bar.close()
    single = single_reflection_brdf(lam, wi, wo, s)
    settings = {"preset": args.preset, "layers": args.layers, "base_albedo": args.base_albedo,
                "incident_deg": list(args.incident), "exit_deg": [list(e) for e in args.exit],
                "samples": args.samples, "blocks": args.blocks, "seed": args.seed, "transmission": args.transmission}
    mean, err, single = (t.reshape(len(args.exit), n) for t in (mean, err, single))
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".json":
            write_json(out, {"wavelength_nm": lam.tolist(), "wi": wi[0].tolist(), "wo": wo.tolist(),
                             "brdf": mean.tolist(), "stderr": err.tolist(), "single_reflection": single.tolist(),
                             "settings": settings})
        else:
            np.savez(out, wavelength_nm=lam.numpy(), wi=wi[0].numpy(), wo=wo.numpy(), brdf=mean.numpy(),
                     stderr=err.numpy(), single_reflection=single.numpy(), settings=json.dumps(settings))
    except OSError as e:
        return _args.cannot_write(NAME, out.parent, e)
    rel = float((err / mean.abs().clamp_min(1e-300)).max())
    print(f"{len(args.exit)} direction pairs × {n} wavelengths, {args.samples} paths each in {args.blocks} blocks "
          f"(seed {args.seed}); {_describe(s, args.preset)}; incidence {args.incident[0]:g}, {args.incident[1]:g}°; "
          f"brdf in sr⁻¹, eq. 34: the single-reflection BRDF")
    print("\n".join(_table(lam, args.exit, mean, err, single)))
    print(_summary(s, lam, args.exit, mean, err, single))
    print(f"largest relative standard error {rel:.3g}; wrote {out}")
    return 0
