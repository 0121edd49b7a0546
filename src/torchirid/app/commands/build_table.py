"""``torchirid build-table``: any public broadcasting function over a grid of named axes, in
chunks, into a resumable Zarr store — in this process, on a local Dask cluster or on a Dask
scheduler (:func:`torchirid.scale.build_table`)."""

from __future__ import annotations

import argparse
import math

from .. import _args

NAME = "build-table"

__all__ = ["NAME", "add_parser", "run"]

#: the public functions a table can be built of (broadcasting, per-point) → the module that exports it
FUNCTIONS = {"bragg_reflectance": "torchirid", "bragg_xyz": "torchirid", "thin_film_reflectance": "torchirid",
             "thin_film_xyz_fourier": "torchirid.ibl", "thin_film_xyz_fitted": "torchirid.ibl",
             "thin_film_xyz_uniform": "torchirid.ibl"}
#: their trailing output shape
CHANNELS = {"bragg_xyz": (3,), "thin_film_xyz_fourier": (3,), "thin_film_xyz_fitted": (3,),
            "thin_film_xyz_uniform": (3,)}


def _axis(text: str):
    """``NAME=START:STOP:COUNT`` → (name, (start, stop, count))."""
    name, sep, spec = text.partition("=")
    parts = spec.split(":")
    if not sep or not name.isidentifier() or len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected NAME=START:STOP:COUNT (e.g. cos_theta=0:1:91); got {text!r}")
    start, stop = _args.number(parts[0]), _args.number(parts[1])
    count = _args.count(parts[2])
    return name, (start, stop, count)


def _function(name: str):
    """The library function ``name`` of :data:`FUNCTIONS`."""
    import importlib

    return getattr(importlib.import_module(FUNCTIONS[name]), name)


def check_arguments(name: str, fn, axes, settings) -> None:
    """ValueError naming what to do unless the --axis and --set names are exactly arguments of
    ``fn`` and give every argument without a default (checked from the signature, before any call):
    an unknown name lists the function's arguments (and the nearest one); missing ones are listed
    with the ``--set NAME=VALUE`` / ``--axis`` forms that give them."""
    import difflib
    import inspect

    params = inspect.signature(fn).parameters
    positional = [p for p, a in params.items() if a.kind in (a.POSITIONAL_ONLY, a.POSITIONAL_OR_KEYWORD)]
    options = [p for p, a in params.items() if a.kind == a.KEYWORD_ONLY]
    takes_any = any(a.kind == a.VAR_KEYWORD for a in params.values())
    signature = (f"{name} takes {', '.join(positional)} (each an --axis or a --set)"
                 + (f" and the options {', '.join(options)} (--set)" if options else ""))
    for option, names in (("--axis", axes), ("--set", settings)):
        unknown = [n for n in names if n not in params]
        if unknown and not takes_any:
            near = difflib.get_close_matches(unknown[0], list(params), n=1)
            hint = f" (did you mean {near[0]}?)" if near else ""
            raise ValueError(f"{option} {unknown[0]}: {name} has no argument {unknown[0]!r}{hint}; {signature}")
    given = set(axes) | set(settings)
    missing = [p for p, a in params.items() if a.default is a.empty
               and a.kind in (a.POSITIONAL_ONLY, a.POSITIONAL_OR_KEYWORD, a.KEYWORD_ONLY) and p not in given]
    if missing:
        example = " ".join(f"--set {p}=VALUE" for p in missing)
        raise ValueError(f"{name} needs a value for {', '.join(missing)}: give each as --set NAME=VALUE (a fixed "
                         f"value, e.g. {example}) or as an axis --axis NAME=START:STOP:COUNT; {signature}")


def add_parser(subparsers):
    """Register ``build-table`` (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="a table of a library function over named axes, chunked and resumable, on Dask → Zarr store",
        description=(
            "Evaluate a public torchirid function over the grid of its --axis arguments, in\n"
            "chunks, into a Zarr store (--out). The other arguments are fixed with --set. A\n"
            "build that is stopped resumes from its finished chunks when run again with the\n"
            "same arguments. Chunks run in this process (default), on a local Dask cluster\n"
            "(--scheduler local --workers N) or on a Dask scheduler (--scheduler tcp://HOST:PORT).\n"
            "Example:\n"
            "  torchirid build-table bragg_xyz --axis cos_theta=0.05:1:96 --axis d1=50:250:81 \\\n"
            "      --set n1=1.0 --set n2=1.5 --set d2=375 --set cells=20 --set method=envelope --out bragg.zarr"
        ),
    )
    p.add_argument("function", choices=tuple(FUNCTIONS), help="the library function")
    p.add_argument("--axis", type=_axis, action="append", required=True, metavar="NAME=START:STOP:COUNT",
                   help="a table axis: COUNT values of argument NAME from START to STOP (repeat per axis)")
    p.add_argument("--set", type=_args.setting, action="append", default=[], metavar="NAME=VALUE",
                   help="a fixed argument (a number, list or string; repeat)")
    p.add_argument("--chunks", type=_args.count, default=64, help="nodes per chunk along every axis (default 64)")
    p.add_argument("--dtype", choices=("float32", "float64"), default="float64",
                   help="precision of the computation and of the stored values")
    _args.add_scheduler_options(p, "chunk")
    p.add_argument("--out", required=True, metavar="STORE", help="the Zarr store (a directory)")
    _args.add_size_option(p)
    _args.add_output_options(p, figures=False)
    p.set_defaults(func=run, parser=p)
    return p


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Build (or resume) the table. Exit status: 0; 1 (scheduler unreachable, write); 2 (bad argument)."""
    import numpy as np
    import torch

    counts = {}
    for name, (_, _, count) in args.axis:
        if name in counts:
            raise ValueError(f"--axis {name} given twice")
        counts[name] = count
    settings = dict(args.set)
    both = sorted(set(counts) & set(settings))
    if both:
        raise ValueError(f"{both[0]} is both an --axis and a --set; give it once")
    fn = _function(args.function)
    check_arguments(args.function, fn, counts, settings)  # from the signature, before any computation
    channels = CHANNELS.get(args.function, ())
    points = math.prod(counts.values())  # the size, before the axes are even allocated
    _args.check_size(NAME, f"the table {' × '.join(map(str, [*counts.values(), *channels]))} of {args.dtype}",
                     points, points * math.prod(channels) * (4 if args.dtype == "float32" else 8), yes=args.yes,
                     quiet=args.quiet, smaller="use smaller axis COUNTs (or --dtype float32)")
    axes = {name: np.linspace(start, stop, count) for name, (start, stop, count) in args.axis}
    try:
        from ...scale import build_table
    except ImportError as e:
        return _args.fail(NAME, f"needs the scale extra (dask, distributed, zarr): {e}", status=1)
    bar = _args.progress_bar(f"{NAME} {args.function}", unit="chunk", quiet=args.quiet)
    progress = _args.progress_callback(bar)
    dtype = torch.float32 if args.dtype == "float32" else torch.float64
    try:
        result = build_table(fn, axes, args.out, chunks=args.chunks, kwargs=settings,
                             channels=channels, dtype=dtype, scheduler=args.scheduler,
                             workers=args.workers, progress=progress, timeout=args.timeout)
    except TypeError as e:  # an --axis or --set name the function does not take
        raise ValueError(f"{args.function}: {e}") from None
    except OSError as e:
        return _args.fail(NAME, e, status=1)
    finally:
        bar.close()
    print(f"{result.computed} chunks computed, {result.skipped} found done; wrote {result.store}")
    return 0
