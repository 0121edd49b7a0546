"""``torchirid gradients``: the atlas of angular colour gradients (Fourneau et al. 2024, Fig. 4) → PNG + ``.npz``."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import _args

NAME = "gradients"
#: ``--preview``: (full, preview) value of each size option
SIZES = {"angles": (90, 16)}

__all__ = ["NAME", "add_parser", "run"]


def _ratio(text: str) -> float:
    value = _args.number(text)
    if not (0.0 < value < 1.0):
        raise argparse.ArgumentTypeError(f"expected a ratio d1/Λ strictly between 0 and 1, got {text!r}")
    return value


def add_parser(subparsers):
    """Register ``gradients`` on an argparse subparsers object (``func=run``); returns its parser."""
    gp = _args.add_command_parser(
        subparsers,
        NAME,
        help="atlas of angular colour gradients of Bragg mirrors (Fourneau et al. 2024, Fig. 4) → .png + .npz",
        description=(
            "Draw the atlas of Fourneau et al. 2024, Fig. 4: Bragg mirrors of N cells of\n"
            "indices n1 and n2, one row per period Λ = d1 + d2 and one column per d1/Λ, plus a\n"
            "first column with a thin film (a slab of index n2 and thickness Λ in n1; air by\n"
            "default). Each cell shows the reflectance against the incidence angle θ (0–90°)\n"
            "at the CMF peaks λ = 599, 556, 442 nm (red, green, blue; the paper's caption\n"
            "prints 559, a typo for 599), above colour strips of the mirror's colour against θ:\n"
            "  ref.             the exact spectrum integrated against the CMFs (method='spectral')\n"
            "  piecewise (s=8)  the library's piecewise approximation (fringe-averaged weights)\n"
            "  paper sub. s=3   the paper's subdivided piecewise approximation (its weights)\n"
            "The thin-film column has the reference strip only. Colours are sRGB under D65\n"
            "(CIE 1931 2°), clipped to [0, 1].\n\n"
            "Writes <out>/<name>.png and <out>/<name>.npz: theta_deg (A,), lambdas_nm (L,),\n"
            "ratios (R,), d1_nm and d2_nm (L, R), srgb_reference, srgb_piecewise and\n"
            "srgb_paper_sub (L, R, A, 3), srgb_thin_film (L, A, 3), the matching unclipped\n"
            "xyz_* arrays, the curves (curve_theta_deg, curve_wavelength_nm,\n"
            "reflectance_bragg (L, R, 721, 3), reflectance_thin_film (L, 721, 3)) and params\n"
            "(a JSON string of every parameter and the torchirid version).\n\n"
            "The default atlas (3 × 5 mirrors, 90 angles) takes about 10 s on a quiet 2-core\n"
            "machine and up to 35 s beside other work; --preview (16 angles) a few seconds."
        ),
    )
    g = gp.add_argument_group("structures")
    g.add_argument("--n1", type=_args.positive, default=1.0, metavar="N",
                   help="real index of layer 1, also the medium around the mirror and the film")
    g.add_argument("--n2", type=_args.positive, default=1.5, metavar="N",
                   help="real index of layer 2 and of the thin film")
    g.add_argument("--cells", type=_args.count, default=20, metavar="COUNT", help="number N of cells of the mirrors")
    g.add_argument("--lambdas", type=_args.positive_length, nargs="+", default=[244.0, 500.0, 988.0], metavar="NM",
                   help="periods Λ = d1 + d2 in nm, one row each (the thin film's thickness too)")
    g.add_argument("--ratios", type=_ratio, nargs="+", default=[0.1, 0.3, 0.5, 0.7, 0.9], metavar="R",
                   help="ratios d1/Λ in (0, 1), one column each")
    g.add_argument("--polarization", choices=_args.POLARIZATIONS, default="unpolarized",
                   help="'unpolarized' is the mean of the s and p reflectances")
    g = gp.add_argument_group("grid and output")
    g.add_argument("--angles", type=_args.whole_number(2, "a gradient needs two angles"), default=None, metavar="COUNT",
                   help="number of incidence angles θ of each colour strip, evenly spaced from 0 to 90° inclusive "
                        "(default: 90; 16 with --preview)")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="gradients", metavar="STEM", help="file stem: writes STEM.png and STEM.npz")
    g.add_argument("--dpi", type=_args.count, default=150, metavar="DPI", help="resolution of the PNG")
    _args.add_preview_option(g, SIZES, full="about 10 s on a quiet 2-core machine, up to 35 s beside other work",
                             quick="a few seconds")
    _args.add_output_options(g)
    gp.set_defaults(func=run, parser=gp)
    return gp


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Compute, draw and write the atlas; prints the two paths. Exit status: 0, 1 (write), 2 (bad argument)."""
    from ..figures import gradients

    _args.resolve_preview(args)
    _args.check_name(args.name)
    if args.n1 > args.n2:
        # the piecewise strips model light propagating in layer 2 at every angle up to 90°
        raise ValueError(f"--n1 ({args.n1:g}) must not exceed --n2 ({args.n2:g}): the piecewise approximations "
                         "need light propagating in layer 2 (no total internal reflection) up to 90°")

    # one bragg_xyz call per method for the whole grid; the bar appears only past 2 s
    bar = _args.progress_bar(f"torchirid {NAME}", total=len(gradients.GRADIENT_ATLAS_STEPS) + 1, quiet=args.quiet)
    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    figures = _args.figure_paths(out, args.name, args.format)
    try:
        atlas = gradients.gradient_atlas(args.lambdas, args.ratios, n1=args.n1, n2=args.n2, cells=args.cells,
                                         polarization=args.polarization, angles=args.angles,
                                         progress=lambda done, total: bar.update(1))
        try:
            out.mkdir(parents=True, exist_ok=True)
            bar.set_postfix_str("figure", refresh=False)
            for path in figures:
                gradients.save_gradient_atlas_png(atlas, path, dpi=args.dpi)
            bar.update()
            gradients.save_gradient_atlas_npz(atlas, npz_path)
        except OSError as e:
            return _args.cannot_write(NAME, out, e)
    finally:
        bar.close()
    for path in [*figures, npz_path]:
        print(path)
    return 0
