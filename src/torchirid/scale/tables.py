r"""Chunked, resumable table builds on Dask: any broadcasting library function over a grid of
named axes, written chunk by chunk to a Zarr store.

A table is ``values[i_1, …, i_k, *C] = fn(**{a_j: axes[a_j][i_j]}, **kwargs)``: each axis is a
keyword argument of ``fn`` that broadcasts along its own dimension (the library's functions
broadcast every argument), ``C`` the function's trailing output axes (e.g. 3 for XYZ). The grid
is cut into chunks (``chunks`` nodes per axis); each chunk is one task: it evaluates ``fn`` on its
slice of every axis and writes its block of the Zarr array ``values`` and then its flag in the
array ``done`` (one flag per chunk, stored as its own object). A build that is stopped — killed,
a worker lost, Ctrl-C — resumes by computing only the chunks whose flag is not set: the store
records the axes, the function and its arguments (``builder``, ``parameters``) and a content
hash of all of them, and refuses to resume a different build.

Where chunks run: ``client=None, scheduler=None`` evaluates them in this process (no Dask
needed); ``scheduler="local"`` starts an embedded ``distributed.LocalCluster`` (``workers``
processes); any other ``scheduler`` string is the address of a running Dask scheduler
(``tcp://host:8786``: dask-jobqueue, Kubernetes, …), or pass a ``distributed.Client``. Dask
reschedules the chunks of a worker that dies; no scheduler, pool or retry loop lives here. A
chunk's values do not depend on where it runs, so every way of building gives the same bits.

The result: :func:`read_table` → the library's :class:`~torchirid.lut.LUT` (axes, units, builder,
parameters), or :func:`open_table` → a lazy Dask array.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import itertools
import json
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import torch

from ..lut import LUT

__all__ = ["build_table", "read_table", "local_cluster", "open_table", "TableBuild"]

#: format of the store's attributes (bump when their meaning changes)
FORMAT = "torchirid-table/1"


def _zarr():
    try:
        return importlib.import_module("zarr")
    except ImportError as e:  # pragma: no cover (a dependency of torchirid[scale])
        raise ImportError("torchirid.scale needs zarr: pip install 'torchirid[scale]'") from e


def _qualified(fn) -> str:
    module, name = getattr(fn, "__module__", None), getattr(fn, "__qualname__", None)
    if not module or not name or "<" in name:
        raise ValueError(f"fn must be a module-level function (importable by name on the workers); got {fn!r}")
    return f"{module}:{name}"


def _resolve(qualified: str):
    module, name = qualified.split(":")
    obj = importlib.import_module(module)
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _check_axes(axes) -> dict[str, np.ndarray]:
    if not isinstance(axes, Mapping) or not axes:
        raise ValueError("axes must be a non-empty mapping {argument name: 1-D grid}")
    out = {}
    for name, grid in axes.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"axes keys must be argument names; got {name!r}")
        g = np.asarray(grid.detach().cpu() if isinstance(grid, torch.Tensor) else grid, dtype=np.float64)
        if g.ndim != 1 or g.size < 1 or not np.isfinite(g).all():
            raise ValueError(f"axes[{name!r}] must be a finite 1-D grid; got shape {g.shape}")
        out[name] = g
    return out


def _check_chunks(chunks, axes) -> tuple[int, ...]:
    if isinstance(chunks, int) and not isinstance(chunks, bool):
        chunks = {name: chunks for name in axes}
    if not isinstance(chunks, Mapping) or set(chunks) - set(axes):
        raise ValueError(f"chunks must be an int or a mapping over the axes {list(axes)}; got {chunks!r}")
    sizes = []
    for name, g in axes.items():
        c = chunks.get(name, g.size)
        if isinstance(c, bool) or not isinstance(c, int) or c < 1:
            raise ValueError(f"chunks[{name!r}] must be an int >= 1; got {c!r}")
        sizes.append(min(c, g.size))
    return tuple(sizes)


def _content_hash(builder, parameters, axes, chunks, dtype) -> str:
    h = hashlib.sha256()
    h.update(json.dumps({"builder": builder, "parameters": parameters, "chunks": chunks, "dtype": dtype,
                         "axes": list(axes)}, sort_keys=True).encode())
    for g in axes.values():
        h.update(g.tobytes())
    return h.hexdigest()


def table_chunks(shape, chunks) -> list[tuple[int, ...]]:
    """Indices of every chunk of a grid of ``shape`` cut into ``chunks`` (row-major).

    Example (a 3 × 5 grid in chunks of 2 × 2 nodes: 2 × 3 chunks, the last ones partial):
        >>> table_chunks((3, 5), (2, 2))
        [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]
    """
    return list(itertools.product(*(range(math.ceil(n / c)) for n, c in zip(shape, chunks))))


class TableBuild:
    """What :func:`build_table` did: the store, the chunks computed now and those found done.

    Attributes: ``store`` (a ``Path``), ``computed`` and ``skipped`` (numbers of chunks).

    Example (a build, then the same build again: every chunk is found done and skipped):
        >>> import os, tempfile, torchirid
        >>> axes = {"wavelength": [450.0, 550.0, 650.0], "thickness": [100.0, 300.0]}  # nm
        >>> kw = {"cos_theta": 1.0, "n_film": 1.33, "n_substrate": 1.5}
        >>> with tempfile.TemporaryDirectory() as d:
        ...     store = os.path.join(d, "r.zarr")
        ...     first = build_table(torchirid.thin_film_reflectance, axes, store, chunks=2, kwargs=kw)
        ...     again = build_table(torchirid.thin_film_reflectance, axes, store, chunks=2, kwargs=kw)
        >>> (first.computed, first.skipped), (again.computed, again.skipped), first.store.name
        ((2, 0), (0, 2), 'r.zarr')
    """

    def __init__(self, store: Path, computed: int, skipped: int):
        self.store, self.computed, self.skipped = store, computed, skipped

    def __repr__(self):
        return f"TableBuild(store={str(self.store)!r}, computed={self.computed}, skipped={self.skipped})"


def _chunk_task(store: str, index: tuple[int, ...]) -> tuple[int, ...]:
    """Evaluate and write one chunk (runs on a worker: everything it needs is in the store)."""
    zarr = _zarr()
    group = zarr.open_group(store, mode="r+")
    attrs = group.attrs.asdict()
    fn = _resolve(attrs["function"])
    names = attrs["axes"]
    chunks = attrs["chunks"]
    dtype = getattr(torch, attrs["dtype"])
    k = len(names)
    args = {}
    sel = []
    for j, (name, i, c) in enumerate(zip(names, index, chunks)):
        grid = group[f"axis_{name}"][:]
        lo, hi = i * c, min((i + 1) * c, grid.size)
        sel.append(slice(lo, hi))
        t = torch.as_tensor(grid[lo:hi], dtype=dtype)
        args[name] = t.reshape(*([1] * j), -1, *([1] * (k - j - 1)))
    with torch.no_grad():
        out = fn(**args, **attrs["kwargs"])
    shape = tuple(s.stop - s.start for s in sel)
    channels = tuple(group["values"].shape[k:])
    block = out.detach().to("cpu").expand(*shape, *channels).numpy()
    group["values"][tuple(sel)] = block
    group["done"][index] = True  # after the values: a set flag means the block is on disk
    return index


def build_table(fn: Callable, axes: Mapping, store, *, chunks: int | Mapping[str, int] = 64, kwargs=None,
                channels: tuple[int, ...] = (), dtype: torch.dtype = torch.float64, units=None,
                client=None, scheduler: str | None = None, workers: int = 2, progress=None,
                timeout: float = 10.0) -> TableBuild:
    r"""Evaluate ``fn`` over the grid ``axes`` in chunks, into the Zarr store ``store`` (resumable).

    Args:
        fn: a module-level library function that broadcasts its arguments (e.g.
            :func:`torchirid.bragg_xyz`, :func:`torchirid.thin_film_reflectance`).
        axes: ``{argument name: 1-D grid}`` in the table's axis order (the values are float64 on
            disk and ``dtype`` when passed to ``fn``).
        store: path of the Zarr store (a directory); created, or resumed if it holds the same build.
        chunks: nodes per chunk, one int for every axis or ``{name: int}`` (default 64).
        kwargs: the other (fixed) arguments of ``fn``: JSON values (numbers, strings, lists).
        channels: ``fn``'s trailing output shape (``(3,)`` for XYZ; ``()`` for a scalar).
        dtype: the dtype ``fn`` computes in and the table stores (default float64).
        units: ``{axis name or "values": unit}`` stored with the table (as :class:`LUT`).
        client, scheduler, workers: where the chunks run (module docstring): a
            ``distributed.Client``; or ``scheduler="local"`` (an embedded ``LocalCluster`` of
            ``workers`` processes) or a scheduler address; default: this process.
        progress: ``None`` or a callable ``progress(done, total)``: chunks finished (found done
            in the store included) out of all chunks, first at the start, then as chunks finish
            (the CLI draws a bar with it).
        timeout: seconds to wait for a scheduler address before a clear error.

    Returns:
        :class:`TableBuild` (store path, chunks computed now, chunks found done).

    Raises:
        ValueError: bad arguments, or a store that holds a different build (another function,
            arguments, axes or chunking: its content hash differs).
        OSError: a scheduler address that does not answer within ``timeout`` seconds.

    Example:
        >>> import os, tempfile, torchirid
        >>> from torchirid.scale import build_table, read_table
        >>> with tempfile.TemporaryDirectory() as d:
        ...     path = os.path.join(d, "r.zarr")
        ...     b = build_table(torchirid.thin_film_reflectance, {"wavelength": [450.0, 550.0, 650.0],
        ...                     "thickness": [100.0, 300.0]}, path, chunks=2,
        ...                     kwargs={"cos_theta": 1.0, "n_film": 1.33, "n_substrate": 1.5})
        ...     shape = tuple(read_table(path).values.shape)
        >>> b.computed, shape
        (2, (3, 2))
    """
    zarr = _zarr()
    qualified = _qualified(fn)
    grids = _check_axes(axes)
    sizes = _check_chunks(chunks, grids)
    kwargs = dict(kwargs or {})
    try:
        kwargs = json.loads(json.dumps(kwargs))
    except (TypeError, ValueError) as e:
        raise ValueError(f"kwargs must be JSON values (numbers, strings, lists): {e}") from None
    overlap = set(kwargs) & set(grids)
    if overlap:
        raise ValueError(f"kwargs and axes both name {sorted(overlap)}")
    if not isinstance(channels, tuple) or not all(isinstance(c, int) and c >= 1 for c in channels):
        raise ValueError(f"channels must be a tuple of ints >= 1 (fn's trailing output shape); got {channels!r}")
    if dtype not in (torch.float32, torch.float64):
        raise ValueError(f"dtype must be torch.float32 or torch.float64; got {dtype!r}")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    dtype_name = str(dtype).removeprefix("torch.")
    _probe(fn, qualified, grids, kwargs, channels, dtype)
    digest = _content_hash(qualified, kwargs, grids, sizes, dtype_name)
    path = Path(os.fspath(store))
    shape = tuple(g.size for g in grids.values())
    grid_chunks = tuple(math.ceil(n / c) for n, c in zip(shape, sizes))
    group = None
    if (path / "zarr.json").exists() or (path / ".zgroup").exists():
        group = zarr.open_group(str(path), mode="r+")
        found = group.attrs.get("content_hash")
        if found != digest:
            if "done" in group and bool(np.asarray(group["done"][...]).any()):
                raise ValueError(f"store {str(path)!r} holds a different table build (content hash {found!r}); "
                                 "remove it or pass another store")
            group = None  # a different build that finished no chunk (e.g. it failed at once): start over
    if group is None:
        group = zarr.open_group(str(path), mode="w")
        for name, g in grids.items():
            group.create_array(f"axis_{name}", data=g)
        group.create_array("values", shape=shape + channels, chunks=sizes + channels, dtype=dtype_name,
                           fill_value=np.nan)
        group.create_array("done", shape=grid_chunks, chunks=(1,) * len(grid_chunks), dtype=bool, fill_value=False)
        group.attrs.update({"format": FORMAT, "function": qualified, "builder": f"torchirid.scale.build_table({qualified})",
                            "axes": list(grids), "chunks": list(sizes), "kwargs": kwargs, "dtype": dtype_name,
                            "units": dict(units or {}), "content_hash": digest,
                            "torchirid_version": _version()})
    done = np.asarray(group["done"][...], dtype=bool)
    todo = [idx for idx in table_chunks(shape, sizes) if not done[idx]]
    total = done.size
    finished = total - len(todo)
    if progress is not None:
        progress(finished, total)
    if todo:
        # an absolute path: workers may run in another directory (a shared filesystem is assumed)
        _run(todo, str(path.resolve()), client, scheduler, workers, timeout, progress, finished, total)
    return TableBuild(path, len(todo), total - len(todo))


def _probe(fn, qualified, grids, kwargs, channels, dtype):
    """One call at the first node of every axis, before anything is written: arguments that
    ``fn`` does not take, bad values there, and a ``channels`` that is not ``fn``'s trailing
    output shape are reported now, not by the first chunk."""
    k = len(grids)
    args = {name: torch.as_tensor(g[:1], dtype=dtype).reshape(*([1] * j), 1, *([1] * (k - j - 1)))
            for j, (name, g) in enumerate(grids.items())}
    try:
        with torch.no_grad():
            out = fn(**args, **kwargs)
    except TypeError as e:  # a missing or unknown argument
        raise ValueError(f"{qualified}: {e}") from None
    if not isinstance(out, torch.Tensor):
        raise ValueError(f"{qualified} must return one tensor; got {type(out).__name__}")
    trailing = tuple(out.shape[k:])
    if out.ndim < k or trailing != channels:
        raise ValueError(f"channels must be {qualified}'s trailing output shape {trailing}; got {channels}")


#: environment of the worker processes of :func:`local_cluster`. Dask's default
#: (``MALLOC_TRIM_THRESHOLD_=65536``: freed memory goes back to the OS at once) makes every
#: large temporary of a chunk a fresh mapping that is page-faulted in again: measured 2.9× slower
#: chunks (``bragg_xyz``, 64 colours: 1.46 s vs 0.50 s in process); with these, 0.46 s.
#: Recommended for any Dask cluster that builds tables (``distributed.nanny.pre-spawn-environ``).
WORKER_ENVIRON = {"MALLOC_TRIM_THRESHOLD_": 1 << 30, "MALLOC_MMAP_THRESHOLD_": 1 << 30}


def local_cluster(workers: int = 2):
    """A ``distributed.LocalCluster`` of ``workers`` single-threaded processes with
    ``WORKER_ENVIRON`` (what ``scheduler="local"`` starts).

    Example (not run here: it starts worker processes; one cluster serving several builds):
        >>> import torchirid  # doctest: +SKIP
        >>> from distributed import Client  # doctest: +SKIP
        >>> cluster = local_cluster(workers=2)  # doctest: +SKIP
        >>> with Client(cluster) as client:  # doctest: +SKIP
        ...     build = build_table(torchirid.thin_film_reflectance,
        ...                         {"wavelength": list(range(380, 781, 5)), "thickness": list(range(0, 1001, 10))},
        ...                         "film.zarr", chunks=32, client=client,
        ...                         kwargs={"cos_theta": 1.0, "n_film": 1.33, "n_substrate": 1.5})
        >>> cluster.close()  # doctest: +SKIP
    """
    import dask
    from distributed import LocalCluster

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1; got {workers!r}")
    environ = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_ENVIRON.items()}
    with dask.config.set(environ):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)


def _run(todo, store, client, scheduler, workers, timeout, progress, finished, total):
    if client is None and scheduler is None:
        for idx in todo:
            _chunk_task(store, idx)
            finished += 1
            if progress is not None:
                progress(finished, total)
        return
    from distributed import as_completed

    with _connected(client, scheduler, workers, timeout) as client:
        futures = [client.submit(_chunk_task, store, idx, key=f"torchirid-chunk-{store}-{idx}", pure=False)
                   for idx in todo]
        for fut in as_completed(futures):
            fut.result()  # a chunk that failed on every retry raises here
            finished += 1
            if progress is not None:
                progress(finished, total)


@contextlib.contextmanager
def _connected(client, scheduler, workers: int = 2, timeout: float = 10.0):
    """The ``distributed.Client`` to run on: ``client`` itself, or one on a new
    :func:`local_cluster` (``scheduler="local"``) or at the address ``scheduler`` — closed (with
    its cluster) on leaving. OSError if the address does not answer within ``timeout`` s."""
    from distributed import Client

    if client is not None:
        yield client
        return
    cluster = local_cluster(workers) if scheduler == "local" else None
    try:
        own = Client(cluster if cluster is not None else scheduler, timeout=timeout)
    except (OSError, TimeoutError) as e:
        if cluster is not None:
            cluster.close()
        raise OSError(f"no Dask scheduler answered at {scheduler!r} within {timeout:g} s ({e})") from None
    try:
        yield own
    finally:
        own.close()
        if cluster is not None:
            cluster.close()


def _version() -> str:
    from .._version import __version__

    return __version__


def _open(store):
    zarr = _zarr()
    path = Path(os.fspath(store))
    if not path.exists():
        raise FileNotFoundError(f"table store {str(path)!r} does not exist")
    group = zarr.open_group(str(path), mode="r")
    attrs = group.attrs.asdict()
    if attrs.get("format") != FORMAT:
        raise ValueError(f"{str(path)!r} is not a torchirid table store (format {attrs.get('format')!r})")
    return group, attrs


def read_table(store) -> LUT:
    """The finished table as a :class:`~torchirid.lut.LUT` (axes, units, builder, parameters);
    ValueError naming the store if chunks are missing (resume the build first).

    Example (R of a water film on glass over wavelength × thickness, in nm):
        >>> import os, tempfile, torchirid
        >>> with tempfile.TemporaryDirectory() as d:
        ...     store = os.path.join(d, "r.zarr")
        ...     _ = build_table(torchirid.thin_film_reflectance, {"wavelength": [450.0, 550.0, 650.0],
        ...                     "thickness": [100.0, 300.0]}, store, chunks=2,
        ...                     kwargs={"cos_theta": 1.0, "n_film": 1.33, "n_substrate": 1.5},
        ...                     units={"wavelength": "nm", "thickness": "nm"})
        ...     lut = read_table(store)
        >>> list(lut.axes), tuple(lut.values.shape), lut.units["thickness"]
        (['wavelength', 'thickness'], (3, 2), 'nm')
        >>> round(float(lut.values[1, 0]), 4)  # R at 550 nm, 100 nm
        0.0069
    """
    group, attrs = _open(store)
    done = np.asarray(group["done"][...], dtype=bool)
    if not done.all():
        raise ValueError(f"table store {str(store)!r} is unfinished: {int((~done).sum())} of {done.size} chunks "
                         "missing (run build_table again to resume)")
    values = torch.as_tensor(np.asarray(group["values"][...]))
    axes = {name: torch.as_tensor(np.asarray(group[f"axis_{name}"][...]), dtype=values.dtype)
            for name in attrs["axes"]}
    return LUT(values, axes, builder=attrs["builder"], parameters={"kwargs": attrs["kwargs"],
               "chunks": attrs["chunks"], "content_hash": attrs["content_hash"]}, units=attrs["units"])


def open_table(store):
    """The table's values as a lazy ``dask.array`` (chunked as built), and its axes as numpy
    arrays: ``(array, {name: grid})``.

    Example (read the values while the store exists: the array is lazy):
        >>> import os, tempfile, torchirid
        >>> with tempfile.TemporaryDirectory() as d:
        ...     store = os.path.join(d, "r.zarr")
        ...     _ = build_table(torchirid.thin_film_reflectance, {"wavelength": [450.0, 550.0, 650.0],
        ...                     "thickness": [100.0, 300.0]}, store, chunks=2,
        ...                     kwargs={"cos_theta": 1.0, "n_film": 1.33, "n_substrate": 1.5})
        ...     values, grids = open_table(store)
        ...     r = float(values[1, 0].compute())  # R at 550 nm, 100 nm
        >>> values.shape, values.chunks, grids["wavelength"].tolist(), round(r, 4)
        ((3, 2), ((2, 1), (2,)), [450.0, 550.0, 650.0], 0.0069)
    """
    import dask.array as da

    group, attrs = _open(store)
    return da.from_zarr(group["values"]), {n: np.asarray(group[f"axis_{n}"][...]) for n in attrs["axes"]}
