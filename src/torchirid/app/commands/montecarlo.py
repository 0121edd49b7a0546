"""``torchirid montecarlo``: the Monte Carlo reference BRDF of a layered Bragg structure in
independent seeded blocks — in this process, on a local Dask cluster or on a Dask scheduler —
bit-identical whatever runs the blocks (:func:`torchirid.scale.montecarlo_brdf_blocks`)."""

from __future__ import annotations

import math

from .. import _args

NAME = "montecarlo"

__all__ = ["NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``montecarlo`` (``func=run``); returns its parser."""
    from ...presets import JEWEL_BEETLE_NAMES

    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="Monte Carlo reference BRDF of a layered Bragg structure in seeded blocks (Dask) → JSON/NPZ",
        description=(
            "Estimate f_r(wi, wo, λ) of a layered Bragg structure (Fourneau et al. 2024,\n"
            "multiple scattering between rough Bragg layers) by path tracing, split into --blocks\n"
            "independent seeded blocks of paths. For the same --seed and --blocks the estimate and\n"
            "its standard error are the same bits whatever runs the blocks: this process\n"
            "(default), a local Dask cluster (--scheduler local --workers N) or a Dask scheduler\n"
            "(--scheduler tcp://HOST:PORT).\n"
            "Writes --out: .json (wavelength_nm, directions, brdf and stderr per pair and\n"
            "wavelength, settings) or .npz (the same arrays). Example:\n"
            "  torchirid montecarlo --preset green --incident 30 0 --exit 30 180 --exit 45 180 \\\n"
            "      --samples 65536 --blocks 32 --scheduler local --workers 4 --out green.json"
        ),
    )
    p.add_argument("--preset", choices=JEWEL_BEETLE_NAMES, default="green",
                   help="the structure: a jewel-beetle preset of Fourneau et al. Table 3 (default green)")
    p.add_argument("--incident", nargs=2, type=_args.number, required=True, metavar=("THETA", "PHI"),
                   help="direction of incidence wi: polar and azimuth angles in degrees")
    p.add_argument("--exit", nargs=2, type=_args.number, action="append", required=True, metavar=("THETA", "PHI"),
                   help="an exit direction wo (degrees; repeat for several)")
    p.add_argument("--wavelengths", nargs=3, metavar=("MIN", "MAX", "COUNT"), default=["400", "700", "7"],
                   help="wavelength grid in nm (default 400 700 7)")
    p.add_argument("--samples", type=_args.count, default=8192, help="paths per direction pair in all (default 8192)")
    p.add_argument("--blocks", type=_args.count, default=16, help="independent seeded blocks (default 16)")
    p.add_argument("--seed", type=_args.count, default=0, help="seed of the whole estimate (default 0)")
    p.add_argument("--transmission", choices=("filter", "microfacet"), default="filter",
                   help="transmission through a rough layer: the F_α filter (default) or sampled microfacets")
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


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Run the blocks and write the estimate. Exit status: 0; 1 (scheduler unreachable, write); 2 (bad argument)."""
    import json
    from pathlib import Path

    import numpy as np
    import torch

    from ... import _checks
    from ..._io import write_json
    from ...presets import jewel_beetle
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
    bar = _args.progress_bar(f"{NAME} {args.preset}", total=args.blocks, unit="block", quiet=args.quiet)
    try:
        mean, err = montecarlo_brdf_blocks(lam, wi, wo, jewel_beetle(args.preset),
                                           samples=args.samples, blocks=args.blocks, seed=args.seed,
                                           scheduler=args.scheduler, workers=args.workers, timeout=args.timeout,
                                           progress=_args.progress_callback(bar), transmission=args.transmission)
    except ImportError as e:
        return _args.fail(NAME, f"--scheduler needs the scale extra (dask, distributed): {e}", status=1)
    except OSError as e:
        return _args.fail(NAME, e, status=1)
    finally:
        bar.close()
    settings = {"preset": args.preset, "incident_deg": list(args.incident), "exit_deg": [list(e) for e in args.exit],
                "samples": args.samples, "blocks": args.blocks, "seed": args.seed, "transmission": args.transmission}
    mean, err = mean.reshape(len(args.exit), n), err.reshape(len(args.exit), n)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".json":
            write_json(out, {"wavelength_nm": lam.tolist(), "wi": wi[0].tolist(), "wo": wo.tolist(),
                             "brdf": mean.tolist(), "stderr": err.tolist(), "settings": settings})
        else:
            np.savez(out, wavelength_nm=lam.numpy(), wi=wi[0].numpy(), wo=wo.numpy(), brdf=mean.numpy(),
                     stderr=err.numpy(), settings=json.dumps(settings))
    except OSError as e:
        return _args.cannot_write(NAME, out.parent, e)
    rel = float((err / mean.abs().clamp_min(1e-300)).max())
    print(f"{len(args.exit)} direction pairs × {n} wavelengths, {args.samples} paths each in {args.blocks} blocks; "
          f"largest relative standard error {rel:.3g}; wrote {out}")
    return 0
