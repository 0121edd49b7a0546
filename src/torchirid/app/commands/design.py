"""``torchirid design SPEC.toml --out DIR``: the thin-film stack that meets a target (inverse design).

Reads the problem from TOML (:func:`torchirid.design.read_spec`; the keys are documented in
:mod:`torchirid.design.spec`), runs :func:`torchirid.design.optimise` (``--seed``,
``--time-limit`` and ``--method`` override the file's ``[optimiser]``), analyses the result under
random thickness errors (:func:`torchirid.design.tolerance`, the file's ``[tolerance]`` or σ = 1 nm,
2000 draws) and writes into ``DIR``:

- ``design.json``: the stack (``layers`` [{material, thickness_nm}], ``incident``, ``exit``),
  ``merit``, ``seconds``, ``evaluations``, ``total_thickness_nm``, ``method``, ``history``
  ([seconds, evaluations, best merit]), the problem's ``name`` and a ``tolerance`` summary;
- ``spectra.png``, ``colour.png`` (with colour targets), ``tolerance.png``, ``convergence.png``
  (:mod:`torchirid.app.figures.design`).

A bad spec is a bad argument: one line naming the key, exit status 2, nothing written. The
outputs are written in a temporary folder beside ``DIR`` and moved into it at the end: a failure
leaves ``DIR`` as it was.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from .. import _args

NAME = "design"

__all__ = ["NAME", "add_parser", "run"]

#: the methods of :func:`torchirid.design.optimise` (it checks them too)
METHODS = ("auto", "global", "gradient", "needle")
#: the tolerance analysis without a ``[tolerance]`` table in the spec
TOLERANCE_DEFAULTS = {"sigma": 1.0, "samples": 2000}
#: the example spec named in the help
EXAMPLE = "examples/design/mirror.toml"


def add_parser(subparsers):
    """Register ``design`` (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="inverse design: the thin-film stack (thicknesses, materials) that meets spectral or colour "
             "targets, from a TOML spec → design.json + figures",
        description=(
            "Find the multilayer stack that meets the targets of SPEC (a TOML file: the stack from the\n"
            "incident side down, each thickness fixed or [min, max] in nm, each material a name, an index\n"
            "or a list to choose from; spectral targets R, T or A against wavelength at given angles,\n"
            "colour targets in CIELAB scored by ΔE2000; manufacturability limits; see the keys in\n"
            "torchirid.design.spec). Differential evolution with exact-gradient refinement, then needles\n"
            "when max_layers allows more layers; seeded. Then the design's merit under random thickness\n"
            "errors (the spec's [tolerance], default σ = 1 nm, 2000 draws) and its yield.\n"
            "\n"
            "Writes into --out: design.json (the stack, merit, time, evaluations, history, tolerance\n"
            "summary), spectra.png, colour.png (with colour targets), tolerance.png, convergence.png.\n"
            "A bad spec (an unknown key, min > max, a thickness in metres, an unknown material) is one\n"
            "line naming the key, exit status 2, and nothing is written.\n"
            "\n"
            "Examples:\n"
            f"  torchirid design {EXAMPLE} --out mirror/              # 10-layer TiO2/SiO2 mirror, 550 nm\n"
            "  torchirid design examples/design/antireflection.toml --out ar/ --seed 1  # broadband AR, needles"
        ),
    )
    p.add_argument("spec", metavar="SPEC", help=f"the design problem, a TOML file (e.g. {EXAMPLE})")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created; files in it are replaced)")
    p.add_argument("--seed", type=_args.whole_number(0), default=None,
                   help="random seed, a whole number >= 0: the same seed, the same design (default: the spec's "
                        "[optimiser] seed, else 0)")
    p.add_argument("--time-limit", type=_args.positive, default=None, metavar="S",
                   help="seconds for the optimisation: the global search starts again from new populations "
                        "until they run out (unless the spec's goal is met), keeping the best stack (default: the "
                        "spec's [optimiser] time_limit, else none: one search, to convergence)")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="auto: global search + gradient refinement, then needles when max_layers allows; "
                        "global; gradient: multi-start L-BFGS-B; needle: needles from the spec's stack "
                        "(default: the spec's [optimiser] method, else auto)")
    _args.add_output_options(p)
    p.set_defaults(func=run, parser=p)
    return p


def _tolerance_options(options: dict | None, layers: int) -> dict:
    """The keyword arguments of :func:`torchirid.design.tolerance`, checked before the run
    (σ as :class:`torchirid.design.Robust` checks it, for the spec's layer count)."""
    from ...design import Robust

    opts = dict(TOLERANCE_DEFAULTS if options is None else options)
    opts.setdefault("sigma", TOLERANCE_DEFAULTS["sigma"])
    opts.setdefault("samples", TOLERANCE_DEFAULTS["samples"])
    if not isinstance(opts["samples"], int) or isinstance(opts["samples"], bool) or opts["samples"] < 1:
        raise ValueError(f"tolerance.samples: a whole number ≥ 1; got {opts['samples']!r}")
    if opts.get("relative", False) not in (True, False):  # (a spec's value: a bad argument, status 2)
        raise ValueError(f"tolerance.relative: true or false; got {opts['relative']!r}")
    Robust(sigma=opts["sigma"], relative=opts.get("relative", False)).check("tolerance", layers)
    return opts


def _quantiles(values) -> dict:
    import numpy as np

    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"mean": None, "p05": None, "median": None, "p95": None, "max": None}
    p05, median, p95 = np.quantile(v, [0.05, 0.5, 0.95])
    return {"mean": float(v.mean()), "p05": float(p05), "median": float(median), "p95": float(p95),
            "max": float(v.max())}


def _tolerance_summary(tol, opts: dict) -> dict:
    summary = {"sigma": opts["sigma"], "relative": bool(opts.get("relative", False)), "samples": int(opts["samples"]),
               "seed": int(opts.get("seed", 0)), "nominal_merit": float(tol.nominal),
               "yield": float(tol.yield_fraction), "standard_error": float(tol.standard_error),
               "merit_limit": tol.merit_limit, "delta_e_limit": tol.delta_e_limit, "merit": _quantiles(tol.merits)}
    if tol.delta_e is not None:
        summary["worst_delta_e2000"] = _quantiles(tol.delta_e.max(axis=-1))
    return summary


def _progress(bar):
    """``progress(evaluations, best_merit)`` of :func:`torchirid.design.optimise` on a bar without a total."""

    def progress(evaluations, merit):
        bar.n = evaluations
        bar.set_postfix_str(f"best merit {merit:.4g}", refresh=False)
        bar.refresh()

    return progress


def _existing_ancestor(path: Path) -> Path:
    while not path.exists():
        path = path.parent
    return path


def _publish(tmp: Path, out: Path) -> None:
    """Move the files of ``tmp`` into ``out``: the whole folder when ``out`` does not exist yet."""
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700 folders; give the usual permissions
        try:
            os.rename(tmp, out)
            return
        except OSError:
            if not out.is_dir():  # (created meanwhile: move the files into it)
                raise
    for f in sorted(tmp.iterdir()):
        os.replace(f, out / f.name)
    tmp.rmdir()


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Design the stack and write design.json and the figures. Exit status: 0; 1 (write); 2 (bad spec or argument)."""
    from ..._io import write_json
    from ...design import ColourTarget, optimise, read_spec, tolerance
    from ..figures import design as figures

    try:
        problem, options, tol_spec = read_spec(args.spec)  # SpecError (a ValueError) naming the key
    except OSError as err:  # a folder or an unreadable file given as SPEC
        raise ValueError(f"{args.spec}: {err.strerror or err}") from None
    for name, value in (("seed", args.seed), ("time_limit", args.time_limit), ("method", args.method)):
        if value is not None:
            options[name] = value
    tol_options = _tolerance_options(tol_spec, len(problem.layers))
    label = problem.name or Path(args.spec).stem
    bar = _args.progress_bar(f"{_args.PROG} {NAME} {label}", unit=" stacks", quiet=args.quiet)
    try:
        design = optimise(problem, **options, progress=_progress(bar))
    except ModuleNotFoundError as err:
        if err.name not in ("scipy", "pvlib"):
            raise
        raise ValueError(f"this command needs {err.name}, part of the design extra: "
                         f"pip install 'torchirid[design]'") from None
    finally:
        bar.close()
    tol = tolerance(design, **tol_options) if design.materials else None
    result = design.to_dict()
    result["name"] = problem.name
    result["tolerance"] = None if tol is None else _tolerance_summary(tol, tol_options)

    out = Path(args.out)
    written = []
    tmp = None
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name or 'design'}.", suffix=".tmp",
                                    dir=_existing_ancestor(out.absolute().parent)))
        write_json(tmp / "design.json", result)
        written.append("design.json")
        figs = [("spectra", figures.plot_spectra(design))]
        if any(isinstance(t, ColourTarget) for t in problem.targets):
            figs.append(("colour", figures.plot_colour(design)))
        if tol is not None:
            figs.append(("tolerance", figures.plot_tolerance(tol, sigma=tol_options["sigma"],
                                                             relative=tol_options.get("relative", False))))
        figs.append(("convergence", figures.plot_convergence(design)))
        for stem, fig in figs:
            for path in _args.figure_paths(tmp, stem, args.format):
                figures.save_figure(fig, path)
                written.append(path.name)
        _publish(tmp, out)
        tmp = None
    except OSError as err:
        return _args.cannot_write(NAME, args.out, err)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)

    total = sum(design.thicknesses)
    print(f"{label}: {len(design.materials)} layers, {total:.1f} nm, merit {design.merit:.6g} "
          f"({design.method}, {design.evaluations:,} stacks in {design.seconds:.2f} s)")
    for k, layer in enumerate(design.layers, 1):
        print(f"  {k:3d}  {layer['material']!s:>12}  {layer['thickness_nm']:8.2f} nm")
    if tol is not None:
        print(f"tolerance: yield {tol.yield_fraction:.1%} ± {tol.standard_error:.1%} over {tol_options['samples']} "
              f"draws (σ = {tol_options['sigma']}{'' if tol_options.get('relative') else ' nm'})")
    else:
        print("tolerance: none (every layer was thinner than min_thickness and was removed)")
    for name in written:
        print(out / name)
    return 0
