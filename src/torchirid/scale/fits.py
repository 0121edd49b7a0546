r"""Batch fitting on Dask: many measurements fitted independently, one result table.

:func:`fit_batch` fits every file of a list — hyperspectral cubes with
:func:`torchirid.estimation.estimate_film` (``kind="film"``) or measured scatterograms with
:func:`torchirid.fitting.match_scatterogram` (``kind="scatterogram"``) — in this process, on an
embedded ``LocalCluster`` or on any Dask scheduler, and returns one record per file, in the
order given. A file that cannot be read or fitted gives a record with ``status="error"`` and the
error's one-line message; the others finish. A fit that the fit itself doubts gets
``status="flagged"`` and the reasons in ``flags``: a film estimate whose residual stays far above
the data's noise level, or whose index search fell back from the peaks to a grid (its
``settings["flags"]``); an ambiguous scatterogram match (``ScatterogramFit.ambiguous``). A worker
process that dies is Dask's to handle: its items are rescheduled on the others
(``distributed.scheduler.allowed-failures`` times), then reported as errors like any other.
:func:`write_results` writes the records as JSON, CSV or Parquet (by the file's suffix).

Every record has ``item`` (the path), ``status`` (``"ok"`` / ``"flagged"`` / ``"error"``),
``error`` (None or ``"ExceptionType: message"``), ``flags`` (None or the reasons to doubt the fit,
joined by `` | ``) and ``seconds`` (the item's wall time on its worker); the fit's figures follow
(``torchirid.scale.fits.FIELDS``), None where the item failed. The fits take their own defaults
(``estimate_film``'s ``index_model_name="auto"``, ``match_scatterogram``'s settings); the one
setting a batch supplies is ``estimate_film``'s ``n_substrate``, 1.64 (PET) as in ``torchirid
fit-film``.
"""

from __future__ import annotations

import csv
import os
import time
from pathlib import Path
from typing import Callable, Sequence

from .. import _checks
from .._io import json_ready, write_json

__all__ = ["fit_batch", "write_results"]

#: the kinds of fit, and the columns each adds to the common ones (item, status, error, seconds)
FIELDS = {
    "film": ("n", "index_model", "index_params", "thickness_mean_nm", "thickness_std_nm", "thickness_min_nm",
             "thickness_max_nm", "rms_mean", "pixels", "pixels_valid"),
    "scatterogram": ("period_nm", "delta", "n1", "n2", "cells", "alpha", "exposure", "loss", "delta_e2000",
                     "iterations"),
}
KINDS = tuple(FIELDS)
COMMON = ("item", "status", "error", "flags", "seconds")
#: the statuses of a record: fitted, fitted but doubted by the fit itself (see ``flags``), failed
STATUSES = ("ok", "flagged", "error")
#: the substrate index of a film fit when the batch does not set one (PET, as ``torchirid fit-film --n-substrate``)
FILM_N_SUBSTRATE = 1.64


def _film(path: str, read: dict, fit: dict) -> tuple[dict, list[str]]:
    from ..estimation import estimate_film
    from ..estimation.cube_io import read_cube

    cube = read_cube(path, **read)
    n_substrate = fit.pop("n_substrate", FILM_N_SUBSTRATE)
    est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, n_substrate, **fit)  # (its warnings: its flags)
    d = est.thickness[est.thickness.isfinite()].double()
    rms = est.rms[est.rms.isfinite()].double()
    return {"n": float(est.n), "index_model": est.index_model,
            "index_params": [float(v) for v in est.params.flatten().tolist()] if est.params.numel() <= 8 else None,
            "thickness_mean_nm": float(d.mean()) if d.numel() else None,
            "thickness_std_nm": float(d.std()) if d.numel() > 1 else None,
            "thickness_min_nm": float(d.min()) if d.numel() else None,
            "thickness_max_nm": float(d.max()) if d.numel() else None,
            "rms_mean": float(rms.mean()) if rms.numel() else None,
            "pixels": int(est.thickness.numel()), "pixels_valid": int(d.numel())}, list(est.settings["flags"])


def _scatterogram(path: str, read: dict, fit: dict) -> tuple[dict, list[str]]:
    from ..fitting import read_scatterogram, match_scatterogram

    image = read_scatterogram(path, **read)
    fit.setdefault("projection", image.projection)
    r = match_scatterogram(image.xyz, image.mask, **fit)
    look_alike = [a.label for a in r.alternatives if a.near_degenerate]
    flags = [f"ambiguous: the period's harmonic refit(s) {', '.join(look_alike) or '?'} look the same as the fit "
             "(mean CIEDE2000 below ambiguity_de2000): the scatterogram does not decide the period"
             ] if r.ambiguous else []
    return {"period_nm": r.period, "delta": r.delta, "n1": r.n1, "n2": r.n2, "cells": r.cells, "alpha": r.alpha,
            "exposure": r.exposure, "loss": r.loss, "delta_e2000": r.delta_e2000, "iterations": r.iterations}, flags


#: each kind's fit: (path, read settings, fit settings) → (the record's figures, the fit's flags)
_FITS: dict[str, Callable[[str, dict, dict], tuple[dict, list[str]]]] = {"film": _film, "scatterogram": _scatterogram}


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "(no message)"
    return f"{type(exc).__name__}: {text[:500]}"


def _record(kind: str, item: str, status: str, error: str | None, seconds: float | None, values: dict | None,
            flags: list[str] | None = None) -> dict:
    rec = {"item": item, "status": status, "error": error, "flags": " | ".join(flags) if flags else None,
           "seconds": seconds}
    rec.update({k: (values or {}).get(k) for k in FIELDS[kind]})
    return rec


def fit_item(kind: str, item, read: dict | None = None, fit: dict | None = None) -> dict:
    """Fit one file and return its record; any exception becomes a record with ``status="error"``
    (what runs on a worker: it never raises for a bad input), a fit with flags one with
    ``status="flagged"``.

    ``kind``, ``read`` and ``fit`` as :func:`fit_batch`; ``item``: one file path.

    Example (a 2 × 2 pixel synthetic MgF₂ cube, n = 1.37, with a quick fit; then a missing file):
        >>> import os, tempfile
        >>> from torchirid.estimation import synthetic_cube, write_npz
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> quick = {"thickness_range": [300.0, 500.0], "iterations": 2, "final_iterations": 0}  # nm
        >>> with tempfile.TemporaryDirectory() as d:
        ...     path = os.path.join(d, "film.npz")
        ...     write_npz(path, c.cube, c.wavelength, c.angles_deg)
        ...     rec = fit_item("film", path, fit=quick)
        >>> rec["status"], round(rec["n"], 2), rec["pixels_valid"]
        ('ok', 1.37, 4)
        >>> bad = fit_item("film", "missing.npz")
        >>> bad["status"], bad["error"], bad["n"]
        ('error', "ValueError: cube file 'missing.npz' does not exist", None)
    """
    start = time.perf_counter()
    try:
        values, flags = _FITS[kind](os.fspath(item), dict(read or {}), dict(fit or {}))
    except Exception as exc:  # noqa: BLE001 — one bad input is reported, the batch goes on
        return _record(kind, os.fspath(item), "error", _one_line(exc), time.perf_counter() - start, None)
    return _record(kind, os.fspath(item), "flagged" if flags else "ok", None, time.perf_counter() - start, values,
                   [" ".join(f.split()) for f in flags])


#: the reader and the fit of each kind, and the arguments a file supplies (not settable)
_CALLS = {"film": ("torchirid.estimation.cube_io:read_cube", "torchirid.estimation:estimate_film",
                   {"path", "cube", "wavelength", "cos_theta"}),
          "scatterogram": ("torchirid.fitting:read_scatterogram", "torchirid.fitting:match_scatterogram",
                           {"path", "target_xyz", "mask"})}
#: settings in nm given as (min, max) pairs: checked before any file is read
NM_RANGES = ("thickness_range", "period_range")


def _preflight(kind: str, read: dict, fit: dict) -> None:
    """Refuse settings that would fail every item, before any is read: names the reader or the
    fit does not take (or that the file supplies) and (min, max) ranges in nm that are not."""
    import importlib
    import inspect

    *calls, from_file = _CALLS[kind]
    for target, options, what in zip(calls, (read, fit), ("read", "fit")):
        module, name = target.split(":")
        params = inspect.signature(getattr(importlib.import_module(module), name)).parameters
        for key in options:
            if key in from_file or key not in params:
                why = "comes from each file" if key in from_file else f"is not an argument of {name}"
                raise ValueError(f"{what} setting {key!r} {why}")
    for key in NM_RANGES:
        value = fit.get(key)
        if value is None:
            continue
        lo, hi = _checks.check_range(value, key, unit="nm")
        _checks.check_length_unit((lo, hi), key, shown=value)


def check_batch(kind, items, read=None, fit=None) -> list[str]:
    """Check a batch before any file is read (:func:`fit_batch` does it first): ``kind``, the
    list of ``items`` (returned as strings) and the ``read`` / ``fit`` settings; ValueError otherwise."""
    _checks.check_choice(kind, "kind", _FITS)
    if isinstance(items, (str, bytes, os.PathLike)) or not isinstance(items, Sequence):
        raise ValueError(f"items must be a list of file paths; got {type(items).__name__}")
    if len(items) == 0:
        raise ValueError("items must name at least one file")
    for name, value in (("read", read), ("fit", fit)):
        if value is not None and not isinstance(value, dict):
            raise ValueError(f"{name} must be a dict of keyword arguments; got {type(value).__name__}")
    _preflight(kind, read or {}, fit or {})
    return [os.fspath(i) for i in items]


def fit_batch(kind: str, items, *, read: dict | None = None, fit: dict | None = None, client=None,
              scheduler: str | None = None, workers: int = 2, timeout: float = 10.0, progress=None) -> list[dict]:
    r"""Fit every file of ``items`` independently; one record per file, in order.

    Args:
        kind: ``"film"`` (a hyperspectral cube per file: .npz or ENVI .hdr, fitted with
            :func:`~torchirid.estimation.estimate_film`) or ``"scatterogram"`` (a PNG / OpenEXR
            scatterogram per file, matched with :func:`~torchirid.fitting.match_scatterogram`).
        items: the file paths.
        read: keyword arguments of the reader (``read_cube``: ``angles_deg``;
            ``read_scatterogram``: ``projection``, ``resolution``, ``exposure``, …).
        fit: keyword arguments of the fit (``estimate_film``: ``n_substrate`` (default 1.64),
            ``index_model_name``, ``thickness_range``, …; ``match_scatterogram``:
            ``incident_deg``, ``cells``, ``period_range``, …); what is not given takes the fit's
            own default (estimate_film's and match_scatterogram's, as the ``torchirid`` commands).
        client, scheduler, workers, timeout: where the fits run, as
            :func:`torchirid.scale.build_table` (default: this process, one after the other).
        progress: ``None`` or a callable ``progress(done, total)``: items finished out of
            ``len(items)``, as they finish.

    Returns:
        A list of dicts (``torchirid.scale.fits.FIELDS``): ``status`` is ``"ok"``, ``"flagged"``
        (fitted, with ``flags`` the reasons to doubt the fit: module docstring) or ``"error"``
        (with ``error`` the one-line reason); the batch does not stop at a bad item.

    Raises:
        ValueError: before any file is read, for settings that would fail every item: a name
            the reader or the fit does not take, a ``thickness_range`` / ``period_range`` that
            is not a (min, max) pair in nm.

    Example:
        >>> import tempfile, pathlib
        >>> from torchirid.estimation import synthetic_cube, write_npz
        >>> c = synthetic_cube("mgf2_400", height=4, width=4, seed=1)
        >>> with tempfile.TemporaryDirectory() as d:
        ...     folder = pathlib.Path(d)
        ...     write_npz(folder / "a.npz", c.cube, c.wavelength, c.angles_deg)
        ...     recs = fit_batch("film", [folder / "a.npz", folder / "missing.npz"])
        >>> [(r["status"], r["n"] is not None and abs(r["n"] - 1.38) < 0.02) for r in recs]  # MgF2: n = 1.38
        [('ok', True), ('error', False)]
        >>> recs[1]["error"]  # doctest: +ELLIPSIS
        "ValueError: cube file '...missing.npz' does not exist"
    """
    paths = check_batch(kind, items, read, fit)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    total = len(paths)
    if client is None and scheduler is None:
        out = []
        for path in paths:
            out.append(fit_item(kind, path, read, fit))
            if progress is not None:
                progress(len(out), total)
        return out
    from distributed import as_completed

    from .tables import _connected

    with _connected(client, scheduler, workers, timeout) as client:
        futures = [client.submit(fit_item, kind, p, read, fit, pure=False) for p in paths]
        where = {f.key: i for i, f in enumerate(futures)}
        records: list[dict | None] = [None] * total
        for done, fut in enumerate(as_completed(futures), 1):
            i = where[fut.key]
            try:
                records[i] = fut.result()
            except Exception as exc:  # noqa: BLE001 — e.g. KilledWorker after the allowed retries
                records[i] = _record(kind, paths[i], "error", _one_line(exc), None, None)
            if progress is not None:
                progress(done, total)
        return records


def write_results(path, records: Sequence[dict]) -> Path:
    """Write the records as one table: ``.json`` (a list of objects, strict JSON: non-finite
    numbers as null), ``.csv`` (one row per item; list values joined with ``;``) or ``.parquet``
    (needs ``pyarrow``). Returns the path.

    Example (two records as :func:`fit_batch` returns them, written as CSV):
        >>> import os, tempfile
        >>> recs = [{"item": "a.npz", "status": "ok", "error": None, "seconds": 0.5, "n": 1.37, "index_params": [1.37]},
        ...         {"item": "b.npz", "status": "error", "error": "ValueError: bad file", "seconds": 0.0, "n": None,
        ...          "index_params": None}]
        >>> with tempfile.TemporaryDirectory() as d:
        ...     lines = write_results(os.path.join(d, "fits.csv"), recs).read_text().splitlines()
        >>> for line in lines:
        ...     print(line)
        item,status,error,seconds,n,index_params
        a.npz,ok,,0.5,1.37,1.37
        b.npz,error,ValueError: bad file,0.0,,
    """
    path = Path(os.fspath(path))
    suffix = path.suffix.lower()
    if suffix not in (".json", ".csv", ".parquet"):
        raise ValueError(f"the result table must end in .json, .csv or .parquet; got {str(path)!r}")
    rows = json_ready(list(records))  # non-finite numbers → None
    columns = list(dict.fromkeys(k for r in rows for k in r))
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".json":
        write_json(path, rows)
    elif suffix == ".csv":
        with path.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=columns)
            w.writeheader()
            for r in rows:
                w.writerow({k: ";".join(map(str, v)) if isinstance(v, list) else ("" if v is None else v)
                            for k, v in r.items()})
    else:
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise ValueError("writing .parquet needs pyarrow (pip install pyarrow); or write .json / .csv") from None
        pq.write_table(pa.Table.from_pylist(rows), str(path))
    return path
