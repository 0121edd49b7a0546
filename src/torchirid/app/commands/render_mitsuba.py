"""``torchirid render-mitsuba``: a sphere of a torchirid material rendered by Mitsuba 3 under an
environment map → EXR (linear RGB) + PNG (sRGB)."""

from __future__ import annotations

import re
from pathlib import Path

from .. import _args

NAME = "render-mitsuba"

#: the plugin of each material family (torchirid.mitsuba.register)
FAMILIES = {"thin_film": "torchirid_thin_film", "multilayer": "torchirid_multilayer", "bragg": "torchirid_bragg"}
#: generated environment maps (torchirid.ibl.synthetic_environment scenes), or a uniform white one
MAPS = ("sky", "sun_sky", "indoor", "uniform")
SIZES = {"size": (128, 48), "spp": (256, 16)}

__all__ = ["FAMILIES", "MAPS", "NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``render-mitsuba`` on an argparse subparsers object (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="a sphere of a torchirid material rendered by Mitsuba 3 under an environment map → .exr + .png",
        description=(
            "Render a unit sphere of a thin film, multilayer or Bragg mirror with the torchirid\n"
            "BSDF plugins for Mitsuba 3 (torchirid.mitsuba) under a generated or given\n"
            "environment map, and write <out>/<name>.exr (linear RGB) and <out>/<name>.png (sRGB).\n"
            "The material's parameters are the plugin's, as NAME=VALUE:\n\n"
            "  torchirid render-mitsuba thin_film n_film=1.33 thickness=450 n_substrate=1 --out out/\n"
            "  torchirid render-mitsuba thin_film n_film=1.45 thickness=310 n_substrate=Au alpha=0.2\n"
            "  torchirid render-mitsuba bragg n1=1.56 n2=1.9 d1=90 d2=70 cells=10 alpha=0.15 base_albedo=0.1\n"
            "  torchirid render-mitsuba multilayer design=mirror/design.json --map indoor\n\n"
            "Needs Mitsuba 3 (pip install 'torchirid[mitsuba]'); the LLVM variants (the default\n"
            "when Dr.Jit finds libLLVM >= 16) render 128 px at 256 spp in seconds, the scalar\n"
            "ones (--variant scalar_spectral) in minutes."
        ),
    )
    p.add_argument("family", choices=sorted(FAMILIES), help="the material family (its Mitsuba plugin)")
    p.add_argument("params", nargs="*", type=_args.setting, metavar="NAME=VALUE",
                   help="the plugin's parameters (n_film=1.33 thickness=450 ...; see docs/guide/mitsuba.md)")
    p.add_argument("--map", default="sky", metavar="MAP",
                   help="environment: sky, sun_sky, indoor (generated), uniform (white), or an .exr/.hdr/.npy file "
                        "in torchirid's frame (+z up, row 0 the zenith; default sky)")
    p.add_argument("--size", type=_args.whole_number(8, "pixels"), default=None,
                   help="image side in pixels (default 128; 48 with --preview)")
    p.add_argument("--spp", type=_args.whole_number(1, "samples per pixel"), default=None,
                   help="samples per pixel (default 256; 16 with --preview)")
    p.add_argument("--variant", default=None,
                   help="Mitsuba variant (default llvm_ad_spectral, or scalar_spectral without LLVM); *_rgb "
                        "variants integrate the spectrum to linear sRGB")
    p.add_argument("--elevation", type=_args.number, default=30.0, metavar="DEG",
                   help="camera elevation above the horizon in degrees (default 30)")
    p.add_argument("--exact", action="store_true",
                   help="evaluate the optics with the library itself (torch, through dr.wrap): the reference; slow")
    p.add_argument("--seed", type=_args.whole_number(0, ""), default=0, help="sampler seed (default 0)")
    p.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--name", default=None, metavar="STEM", help="file name stem (default: mitsuba_<family>)")
    _args.add_preview_option(p, SIZES, full="seconds with LLVM", quick="about a second with LLVM")
    _args.add_output_options(p, figures=False)
    p.set_defaults(func=run, parser=p)
    return p


def _plugin_message(exc: Exception) -> str:
    """The plugin's own ValueError line out of Mitsuba's wrapped traceback."""
    text = str(exc)
    found = re.findall(r"ValueError: (.*)", text)
    return found[-1] if found else text.strip().splitlines()[-1]


def _environment(spec: str):
    import numpy as np

    if spec in MAPS:
        if spec == "uniform":
            return np.ones((16, 32, 3), dtype=np.float32)
        from ...ibl import synthetic_environment

        return synthetic_environment(scene=spec).numpy()
    path = Path(spec)
    if path.suffix.lower() == ".npy":
        data = np.load(path)
    else:
        from ...ibl import read_environment

        data = read_environment(path).numpy()
    if data.ndim != 3 or data.shape[-1] != 3:
        raise ValueError(f"--map {spec}: expected an (H, W, 3) RGB map, got shape {data.shape}")
    return data


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Render and write; prints the paths. Exit status: 0, 1 (write), 2 (bad argument, no Mitsuba)."""
    _args.resolve_preview(args)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r} is not a directory")
    name = args.name or f"mitsuba_{args.family}"
    _args.check_name(name)
    if args.map not in MAPS and not Path(args.map).is_file():
        raise ValueError(f"--map {args.map!r}: neither one of {', '.join(MAPS)} nor a file")
    from ...mitsuba import scenes

    scenes.find_libllvm()
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError:
        raise ValueError("needs Mitsuba 3: pip install 'torchirid[mitsuba]'") from None
    import torchirid.mitsuba as tm

    variant = args.variant or scenes.default_variant()
    if variant not in mi.variants():
        raise ValueError(f"--variant {variant!r} is not one of Mitsuba's: {', '.join(mi.variants())}")
    if variant.startswith("llvm") and not dr.has_backend(dr.JitBackend.LLVM):
        raise ValueError(f"--variant {variant}: Dr.Jit has no LLVM backend here (needs libLLVM >= 16, e.g. Debian's "
                         "libllvm19, and DRJIT_LIBLLVM_PATH); use scalar_spectral")
    tm.register(variant)
    params = dict(args.params)
    spec = {"type": FAMILIES[args.family], **params}
    if args.exact:
        spec["evaluator"] = "torch"
    try:
        bsdf = mi.load_dict(spec)
    except RuntimeError as exc:
        raise ValueError(f"{args.family}: {_plugin_message(exc)}") from None
    env = _environment(args.map)
    scene = scenes.sphere_scene(bsdf, environment=env, size=args.size, spp=args.spp, elevation_deg=args.elevation)
    passes = max(1, min(args.spp // 16, 32))
    bar = _args.progress_bar(f"torchirid {NAME}", total=passes, unit="pass", quiet=args.quiet)
    try:
        image = scenes.render(scene, spp=args.spp, seed=args.seed, passes=passes, exact=args.exact,
                              progress=lambda done, total: bar.update(1))
    finally:
        bar.close()
    paths = [out / f"{name}.exr", out / f"{name}.png"]
    try:
        out.mkdir(parents=True, exist_ok=True)
        for path in paths:
            scenes.write_image(image, path)
    except (OSError, RuntimeError) as e:
        return _args.cannot_write(NAME, out, e if isinstance(e, OSError) else OSError(str(e)))
    print(f"{variant}, {args.size}×{args.size} px, {args.spp} spp, map {args.map}")
    for path in paths:
        print(path)
    return 0
