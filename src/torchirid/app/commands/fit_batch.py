"""``torchirid fit-batch {film,scatterogram} FILE... --out TABLE``: many measurements fitted
independently — in this process, on a local Dask cluster or on a Dask scheduler — into one
result table with a status per file (:func:`torchirid.scale.fit_batch`)."""

from __future__ import annotations

from .. import _args

NAME = "fit-batch"
#: the exit status when no file was fitted: 1, the status of a failure after the arguments were checked
NOTHING_FITTED = _args.WRITE_ERROR

__all__ = ["NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``fit-batch`` (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="fit many cubes or scatterograms in parallel (Dask) → one JSON/CSV/Parquet table with a status per file",
        description=(
            "Fit every FILE independently and write one row per file to --out (.json, .csv or\n"
            ".parquet): the fitted figures, 'status' (ok / flagged / error), the one-line error of a\n"
            "file that could not be read or fitted (the others still finish), the 'flags' of a fit\n"
            "that doubts itself (a film residual far above the noise, an ambiguous scatterogram)\n"
            "and the seconds it took. The fits take the library's defaults (film: the index model\n"
            "auto, as fit-film). Exit status 1 when no file was fitted.\n"
            "  film          a hyperspectral cube per file (.npz or ENVI .hdr): film index and\n"
            "                thickness statistics (estimate_film; --set n_substrate=1.64 ...)\n"
            "  scatterogram  a PNG / OpenEXR scatterogram per file: the Bragg layer\n"
            "                (match_scatterogram; --set incident_deg=[30,0] ...)\n"
            "Fits run in this process (default), on a local Dask cluster (--scheduler local\n"
            "--workers N) or on a Dask scheduler (--scheduler tcp://HOST:PORT). Example:\n"
            "  torchirid fit-batch film cubes/*.npz --set n_substrate=1.64 --scheduler local --out fits.csv"
        ),
    )
    p.add_argument("kind", choices=("film", "scatterogram"), help="what each file holds")
    p.add_argument("files", nargs="+", metavar="FILE", help="the measurements, one fit each")
    p.add_argument("--set", type=_args.setting, action="append", default=[], metavar="NAME=VALUE",
                   help="an argument of the fit (estimate_film / match_scatterogram; repeat)")
    p.add_argument("--read", type=_args.setting, action="append", default=[], metavar="NAME=VALUE",
                   help="an argument of the reader (read_cube: angles_deg; read_scatterogram: projection, "
                        "resolution, exposure, ...; repeat)")
    _args.add_scheduler_options(p, "fit")
    p.add_argument("--out", required=True, metavar="TABLE", help="the result table: .json, .csv or .parquet")
    _args.add_output_options(p, figures=False)
    p.set_defaults(func=run, parser=p)
    return p


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Fit the files and write the table. Exit status: 0 (at least one file fitted, ok or flagged: the
    per-file statuses are in the table), 1 (no file fitted — the table still lists the errors —,
    scheduler unreachable, write failed), 2 (bad argument)."""
    from pathlib import Path

    from ...scale.fits import check_batch, fit_batch, write_results

    check_batch(args.kind, args.files, dict(args.read), dict(args.set))  # settings that would fail every file
    out = Path(args.out)
    if out.suffix.lower() not in (".json", ".csv", ".parquet"):
        raise ValueError(f"--out must end in .json, .csv or .parquet; got {args.out!r}")
    bar = _args.progress_bar(f"{NAME} {args.kind}", total=len(args.files), unit="file", quiet=args.quiet)
    try:
        records = fit_batch(args.kind, args.files, read=dict(args.read), fit=dict(args.set),
                            scheduler=args.scheduler, workers=args.workers, timeout=args.timeout,
                            progress=_args.progress_callback(bar))
    except ImportError as e:
        return _args.fail(NAME, f"--scheduler needs the scale extra (dask, distributed): {e}", status=1)
    except OSError as e:
        return _args.fail(NAME, e, status=1)
    finally:
        bar.close()
    try:
        write_results(out, records)
    except OSError as e:
        return _args.cannot_write(NAME, out.parent, e)
    failed = [r for r in records if r["status"] == "error"]
    flagged = [r for r in records if r["status"] == "flagged"]
    print(f"{len(records) - len(failed)} of {len(records)} items fitted ({len(flagged)} flagged), {len(failed)} failed; "
          f"wrote {out}")
    shown = [(r["item"], f"flagged: {r['flags']}") for r in flagged] + [(r["item"], r["error"]) for r in failed]
    for item, why in shown[:10]:
        print(f"  {item}: {why}")
    if len(shown) > 10:
        print(f"  ... and {len(shown) - 10} more (see the table)")
    if len(failed) == len(records):  # nothing fitted: the batch failed, whatever the table says
        return _args.fail(NAME, f"no file was fitted ({len(failed)} of {len(failed)} failed; the errors are in {out})",
                          status=NOTHING_FITTED)
    return 0
