"""``torchirid spectrum``: the reflectance map R(θ, λ) of a Bragg mirror or a thin film → ``.npz`` + PNG."""

from __future__ import annotations

from pathlib import Path

from .. import _args

NAME = "spectrum"
KINDS = ("bragg", "thin-film")

__all__ = ["KINDS", "NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``spectrum`` on an argparse subparsers object (``func=run``); returns its parser."""
    sp = _args.add_command_parser(
        subparsers,
        NAME,
        help="reflectance map R(incidence angle, wavelength) of a Bragg mirror or thin film → .npz + .png",
        description=(
            "Compute the specular reflectance R of a Bragg mirror (N cells of two layers,\n"
            "Fourneau et al. 2024) or of a single thin film (Airy sum) on a grid of\n"
            "incidence angles θ from 0° to 90° (inclusive) × wavelengths, and write\n"
            "<out>/<name>.npz and <out>/<name>.png.\n\n"
            "The .npz holds wavelength_nm (W,), theta_deg (A,), cos_theta (A,),\n"
            "reflectance (A, W) and params (a JSON string of every parameter and the\n"
            "torchirid version). Refractive indices may be complex, n + iκ with κ >= 0\n"
            "meaning absorption, written like 1.5+0.02j.\n\n"
            "The defaults are the Bragg mirror of Fourneau et al. 2024, Fig. 1 (left):\n"
            "n1 = 1, n2 = 1.5, d1 = 125 nm, d2 = 375 nm, N = 20, in air."
        ),
    )
    sp.add_argument("--kind", choices=KINDS, default="bragg", help="structure to compute")

    g = sp.add_argument_group(
        "Bragg mirror (--kind bragg)", "the stack n_incident | (n2, d2), (n1, d1) × cells | n1, lit from n_incident"
    )
    g.add_argument(
        "--n1", type=_args.index, default=1.0, metavar="N", help="index of layer 1 (also the medium below the mirror)"
    )
    g.add_argument("--n2", type=_args.index, default=1.5, metavar="N", help="refractive index of layer 2")
    g.add_argument("--d1", type=_args.length, default=125.0, metavar="NM", help="thickness of layer 1 in nm")
    g.add_argument("--d2", type=_args.length, default=375.0, metavar="NM", help="thickness of layer 2 in nm")
    g.add_argument("--cells", type=int, default=20, metavar="COUNT", help="number N of cells (layer pairs)")

    g = sp.add_argument_group(
        "thin film (--kind thin-film)", "the stack n_incident | (n_film, thickness) | n_substrate, lit from n_incident"
    )
    g.add_argument("--n-film", type=_args.index, default=1.5, metavar="N", help="refractive index of the film")
    g.add_argument("--thickness", type=_args.length, default=375.0, metavar="NM", help="film thickness in nm")
    g.add_argument(
        "--n-substrate", type=_args.index, default=1.0, metavar="N", help="refractive index of the medium below the film"
    )
    g = sp.add_argument_group("both kinds")
    g.add_argument(
        "--n-incident", type=_args.index, default=None, metavar="N",
        help="real index of the incident medium above the structure; default: n1 (bragg), 1.0 (thin-film)",
    )

    g = sp.add_argument_group("grid and output")
    g.add_argument(
        "--polarization",
        choices=_args.POLARIZATIONS,
        default="unpolarized",
        help="'unpolarized' is the mean of the s and p reflectances",
    )
    g.add_argument(
        "--wavelengths",
        nargs=3,
        metavar=("MIN", "MAX", "COUNT"),
        default=["380", "780", "401"],
        help="wavelength grid in nm: COUNT evenly spaced values from MIN to MAX inclusive",
    )
    g.add_argument(
        "--angles",
        type=_args.count,
        default=91,
        metavar="COUNT",
        help="number of incidence angles θ (degrees, in the incident medium), evenly spaced from 0 to 90 inclusive "
             "(default 91: every degree)",
    )
    g.add_argument("--dtype", choices=("float64", "float32"), default="float64", help="precision of the computation")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="spectrum", metavar="STEM", help="file stem: writes STEM.npz and STEM.png")
    _args.add_size_option(g)
    _args.add_output_options(g)
    sp.set_defaults(func=run, parser=sp)
    return sp


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Compute, draw and write the map; prints the two paths. Exit status: 0, 1 (write), 2 (bad argument)."""
    from ..figures import reflectance_maps

    wavelengths = _args.parse_wavelengths(args.wavelengths)
    _args.check_name(args.name)
    _args.check_size(NAME, f"the map {args.angles} angles × {wavelengths[2]} wavelengths of {args.dtype}",
                     args.angles * wavelengths[2], args.angles * wavelengths[2] * (4 if args.dtype == "float32" else 8),
                     yes=args.yes, quiet=args.quiet, smaller="use fewer --angles or a smaller --wavelengths COUNT")
    grid = dict(wavelengths=wavelengths, angles=args.angles, polarization=args.polarization, dtype=args.dtype)
    if args.kind == "bragg":
        rmap = reflectance_maps.bragg_reflectance_map(
            args.n1, args.n2, args.d1, args.d2, args.cells, n_incident=args.n_incident, **grid
        )
    else:
        rmap = reflectance_maps.thin_film_reflectance_map(
            args.n_film, args.thickness, args.n_substrate,
            n_incident=1.0 if args.n_incident is None else args.n_incident, **grid
        )

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    figures = _args.figure_paths(out, args.name, args.format)
    try:
        out.mkdir(parents=True, exist_ok=True)
        reflectance_maps.save_reflectance_map_npz(rmap, npz_path)
        for path in figures:
            reflectance_maps.save_reflectance_map_png(rmap, path, dpi=120)
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    print(npz_path)
    for path in figures:
        print(path)
    return 0
