"""The ``torchirid`` command.

``torchirid spectrum`` computes the reflectance R(θ, λ) of a Bragg mirror or a thin film on
a grid of incidence angles × wavelengths and writes ``<out>/<name>.npz`` (the arrays and a
JSON ``params`` string) and ``<out>/<name>.png`` (a reflectance map).

On the command line, wavelengths and thicknesses are in nm and incidence angles in degrees
(the library itself takes cos θ). Heavy imports (torch, numpy, matplotlib) happen inside
the command so that ``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from pathlib import Path

PROG = "torchirid"
POLARIZATIONS = ("s", "p", "unpolarized")
KINDS = ("bragg", "thin-film")
DTYPES = ("float64", "float32")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Show defaults and keep the hand-made line breaks of descriptions and epilogs."""

    def _get_help_string(self, action):
        if action.default is None or action.default is argparse.SUPPRESS or not action.option_strings:
            return action.help
        if isinstance(action.default, (list, tuple)):
            return f"{action.help} (default: {' '.join(map(str, action.default))})"
        return super()._get_help_string(action)


def _index(text: str):
    """A refractive index n or n + iκ from the command line: ``1.5``, ``1.5+0.02j``."""
    try:
        return float(text)
    except ValueError:
        pass
    try:
        z = complex(text.replace(" ", "").replace("i", "j"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a refractive index such as 1.5 or 1.5+0.02j (n + iκ), got {text!r}"
        ) from None
    return z.real if z.imag == 0 else z


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {value}")
    return value


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _json_index(n):
    """Refractive indices in the JSON params: a number, or [re, im] when complex."""
    return [n.real, n.imag] if isinstance(n, complex) else n


def _fmt_index(n) -> str:
    if isinstance(n, complex):
        return f"{n.real:g}{n.imag:+g}i"
    return f"{n:g}"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        formatter_class=_HelpFormatter,
        description=(
            "torchirid: exact, differentiable reflectance of iridescent materials\n"
            "(thin films, multilayers, Bragg mirrors) in PyTorch.\n\n"
            "Units on the command line: wavelengths and thicknesses in nm, incidence\n"
            "angles in degrees (the Python API takes cos θ)."
        ),
        epilog=(
            "examples:\n"
            "  torchirid spectrum                       # Fourneau et al. 2024, Fig. 1 Bragg mirror\n"
            "  torchirid spectrum --kind thin-film --n-film 1.33 --thickness 400\n"
            "  torchirid spectrum --help                # all options"
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    sp = sub.add_parser(
        "spectrum",
        formatter_class=_HelpFormatter,
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
        "Bragg mirror (--kind bragg)", "the stack n_host | (n2, d2), (n1, d1) × cells | n1, lit from n_host"
    )
    g.add_argument(
        "--n1", type=_index, default=1.0, metavar="N", help="index of layer 1 (also the medium below the mirror)"
    )
    g.add_argument("--n2", type=_index, default=1.5, metavar="N", help="refractive index of layer 2")
    g.add_argument("--d1", type=_float, default=125.0, metavar="NM", help="thickness of layer 1 in nm")
    g.add_argument("--d2", type=_float, default=375.0, metavar="NM", help="thickness of layer 2 in nm")
    g.add_argument("--cells", type=int, default=20, metavar="COUNT", help="number N of cells (layer pairs)")
    g.add_argument(
        "--n-host",
        type=_index,
        default=None,
        metavar="N",
        help="real index of the host (incident) medium above the mirror; default: n1",
    )

    g = sp.add_argument_group(
        "thin film (--kind thin-film)", "the stack n_outer | (n_film, thickness) | n_substrate, lit from n_outer"
    )
    g.add_argument("--n-film", type=_index, default=1.5, metavar="N", help="refractive index of the film")
    g.add_argument("--thickness", type=_float, default=375.0, metavar="NM", help="film thickness in nm")
    g.add_argument(
        "--n-substrate", type=_index, default=1.0, metavar="N", help="refractive index of the medium below the film"
    )
    g.add_argument(
        "--n-outer", type=_index, default=1.0, metavar="N", help="index of the incident medium above the film (real)"
    )

    g = sp.add_argument_group("grid and output")
    g.add_argument(
        "--polarization",
        choices=POLARIZATIONS,
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
        type=_count,
        default=90,
        metavar="COUNT",
        help="number of incidence angles θ (degrees, in the incident medium), evenly spaced from 0 to 90 inclusive",
    )
    g.add_argument("--dtype", choices=DTYPES, default="float64", help="precision of the computation")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="spectrum", metavar="STEM", help="file stem: writes STEM.npz and STEM.png")
    sp.set_defaults(func=_cmd_spectrum, parser=sp)
    return parser


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("torchirid")
    except Exception:  # not installed (e.g. run from a source tree via PYTHONPATH)
        return "unknown"


def _parse_wavelengths(parser: argparse.ArgumentParser, raw) -> tuple[float, float, int]:
    lo, hi, count = raw
    try:
        lo, hi = float(lo), float(hi)
    except ValueError:
        parser.error(f"--wavelengths: MIN and MAX must be numbers (nm); got {raw[0]!r} {raw[1]!r}")
    try:
        count = _count(count)
    except argparse.ArgumentTypeError as e:
        parser.error(f"--wavelengths COUNT: {e}")
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi < lo:
        parser.error(f"--wavelengths: need 0 < MIN <= MAX (nm); got MIN={lo:g} MAX={hi:g}")
    if count > 1 and hi == lo:
        parser.error("--wavelengths: MIN == MAX needs COUNT 1")
    return lo, hi, count


def _cmd_spectrum(args: argparse.Namespace) -> int:
    parser: argparse.ArgumentParser = args.parser
    wl_min, wl_max, wl_count = _parse_wavelengths(parser, args.wavelengths)
    if not args.name or os.sep in args.name or (os.altsep and os.altsep in args.name):
        parser.error(f"--name must be a plain file stem, got {args.name!r}")

    import numpy as np
    import torch

    import torchirid

    dtype = getattr(torch, args.dtype)
    cdtype = torch.complex128 if dtype == torch.float64 else torch.complex64

    def real(x):
        return torch.tensor(x, dtype=dtype)

    def index(n):
        # build complex constants directly in the target precision (never float32 cast up)
        return torch.tensor(n, dtype=cdtype if isinstance(n, complex) else dtype)

    wavelength_nm = np.linspace(wl_min, wl_max, wl_count)
    theta_deg = np.linspace(0.0, 90.0, args.angles)
    # cos 90° is 6e-17, not 0; clip guards against any rounding outside [0, 1]
    cos_theta = np.clip(np.cos(np.radians(theta_deg)), 0.0, 1.0)

    wavelength = torch.as_tensor(wavelength_nm, dtype=dtype)[None, :]  # (1, W)
    cos_t = torch.as_tensor(cos_theta, dtype=dtype)[:, None]  # (A, 1)

    params: dict = {"kind": args.kind}
    if args.kind == "bragg":
        n_host = args.n1 if args.n_host is None else args.n_host
        params.update(
            n1=_json_index(args.n1),
            n2=_json_index(args.n2),
            d1_nm=args.d1,
            d2_nm=args.d2,
            cells=args.cells,
            n_host=_json_index(n_host),
        )
        title = (
            f"Bragg mirror: n1={_fmt_index(args.n1)}, n2={_fmt_index(args.n2)}, "
            f"d1={args.d1:g} nm, d2={args.d2:g} nm, N={args.cells}, host n={_fmt_index(n_host)}"
        )
    else:
        params.update(
            n_film=_json_index(args.n_film),
            thickness_nm=args.thickness,
            n_substrate=_json_index(args.n_substrate),
            n_outer=_json_index(args.n_outer),
        )
        title = (
            f"Thin film: n={_fmt_index(args.n_film)}, d={args.thickness:g} nm, "
            f"substrate n={_fmt_index(args.n_substrate)}, outer n={_fmt_index(args.n_outer)}"
        )
    params.update(
        polarization=args.polarization,
        wavelength_min_nm=wl_min,
        wavelength_max_nm=wl_max,
        wavelength_count=wl_count,
        angle_count=args.angles,
        angle_min_deg=0.0,
        angle_max_deg=90.0,
        dtype=args.dtype,
        torchirid_version=getattr(torchirid, "__version__", None) or _version(),
    )

    try:
        with torch.no_grad():
            if args.kind == "bragg":
                R = torchirid.bragg_reflectance(
                    wavelength,
                    cos_t,
                    index(args.n1),
                    index(args.n2),
                    real(args.d1),
                    real(args.d2),
                    args.cells,
                    n_host=index(n_host),
                    polarization=args.polarization,
                )
            else:
                R = torchirid.thin_film_reflectance(
                    wavelength,
                    cos_t,
                    index(args.n_film),
                    real(args.thickness),
                    index(args.n_substrate),
                    n_outer=index(args.n_outer),
                    polarization=args.polarization,
                )
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        parser.error(str(e))

    shape = (args.angles, wl_count)
    R = torch.broadcast_to(R, shape).detach().cpu().numpy()

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    png_path = out / f"{args.name}.png"
    try:
        out.mkdir(parents=True, exist_ok=True)
        _atomic_write(
            npz_path,
            lambda f: np.savez(
                f,
                wavelength_nm=wavelength_nm,
                theta_deg=theta_deg,
                cos_theta=np.asarray(cos_t.squeeze(-1).cpu().numpy()),
                reflectance=R,
                params=np.array(json.dumps(params, sort_keys=True)),
            ),
        )
        fig = _plot(wavelength_nm, theta_deg, R, title, args.polarization)
        try:
            _atomic_write(png_path, lambda f: fig.savefig(f, format="png", dpi=120))
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1

    print(npz_path)
    print(png_path)
    return 0


def _atomic_write(path: Path, write) -> None:
    """Write via a temporary file in the same directory, then rename over ``path``."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _plot(wavelength_nm, theta_deg, R, title: str, polarization: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax_map, ax_lines) = plt.subplots(
        1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1.35, 1]}, layout="constrained"
    )
    finite = R[np.isfinite(R)]
    vmax = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    mesh = ax_map.pcolormesh(wavelength_nm, theta_deg, R, shading="nearest", cmap="magma", vmin=0.0, vmax=vmax)
    fig.colorbar(mesh, ax=ax_map, label="reflectance R")
    ax_map.set_xlabel("wavelength λ (nm)")
    ax_map.set_ylabel("incidence angle θ (degrees)")
    ax_map.set_title(f"R(θ, λ), {polarization}")

    # a few spectra at fixed angles (the grid angles nearest to these)
    picks = sorted({int(np.abs(theta_deg - t).argmin()) for t in (0.0, 30.0, 60.0, 80.0)})
    for i in picks:
        ax_lines.plot(wavelength_nm, R[i], label=f"θ = {theta_deg[i]:.1f}°")
    ax_lines.set_xlabel("wavelength λ (nm)")
    ax_lines.set_ylabel("reflectance R")
    ax_lines.set_ylim(0.0, max(1.0, vmax) * 1.02)
    if len(wavelength_nm) > 1:
        ax_lines.set_xlim(wavelength_nm[0], wavelength_nm[-1])
    ax_lines.grid(alpha=0.3)
    ax_lines.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=len(picks), fontsize="small", frameon=False)
    fig.suptitle(title)
    return fig


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``torchirid`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
