r"""One lookup-table container for every table of torchirid: values, named axes, metadata.

A :class:`LUT` holds

* ``values``: a real floating tensor of shape ``(n_1, ..., n_k, *C)``; the first ``k`` dims
  are the table axes, the trailing dims ``C`` (possibly none) are *channels* (e.g. the three
  X, Y, Z columns of a cumulative colour-matching table);
* ``axes``: an ordered mapping ``name → 1-D strictly increasing grid`` (``len == n_i``,
  at least 2 nodes, finite), stored in the values' dtype and on the values' device;
* metadata: ``builder`` (what built it, e.g. ``"luts/build_cmf.py:cumulative_xyz"``),
  ``parameters`` (a JSON dict of the builder's inputs), ``units`` (``axis name or "values" →
  unit string``, e.g. ``{"omega": "nm", "values": "1"}``), the torchirid version that built
  it, the file-format version, and a content ``hash``.

Interpolation ``lut(**coords)`` is multilinear on the grid, batched (the coordinates
broadcast together with torch rules) and differentiable with respect to the coordinates
and the values.  Out-of-range coordinates are clamped to the grid (``"clamp"``, the
default), refused (``"error"``) or extrapolated from the edge cell (``"linear"``).

File format (``FORMAT_VERSION = 1``)
------------------------------------
A ``.npz`` archive (``numpy.savez``, uncompressed) read with ``allow_pickle=False``; every
member is a plain numeric array, nothing is pickled:

========== ========================================================================
member     content
========== ========================================================================
``values`` the values, in their own dtype (float16, float32 or float64)
``axis_i`` the ``i``-th axis grid (``i = 0 .. k-1``), in the values' dtype
``meta``   UTF-8 JSON object as a ``uint8`` array (see below)
========== ========================================================================

``meta`` keys: ``format`` (``"torchirid.lut"``), ``format_version`` (int), ``builder``
(str), ``parameters`` (dict), ``units`` (dict str → str), ``torchirid_version`` (str),
``axes`` (list of axis names in order), ``shape`` (list of ints), ``dtype`` (``"float64"``,
...), ``hash`` (hex str).

The content hash is the SHA-256 of: the canonical JSON (sorted keys, no spaces, ASCII,
no NaN) of ``meta`` without ``hash``, then the little-endian bytes of every axis in order,
then the little-endian C-order bytes of ``values``.  It therefore identifies the content
*in its dtype*: ``lut.to(torch.float32).hash != lut.hash``.  The loader recomputes it and
refuses a mismatch; it also refuses a file whose builder, parameters or axes differ from
what the caller expects.  Files are written atomically (a temporary file in the same
directory, then :func:`os.replace`), so a crash never leaves a half-written table at the
target path.  Only ``.npz`` is supported; a safetensors backend could be added behind the
same :meth:`LUT.write` / :meth:`LUT.read` if a renderer ever needs it.

Example
-------
>>> import torch
>>> from torchirid.lut import LUT
>>> x = torch.tensor([0.0, 1.0, 2.0], dtype=torch.float64)
>>> lut = LUT(torch.stack([x**2, 2 * x], -1), {"x": x}, builder="doc",
...           units={"x": "nm", "values": "1"})
>>> lut
LUT(axes=[x: 3 in [0, 2]], channels=(2,), dtype=float64, device=cpu, builder='doc')
>>> lut(x=torch.tensor([0.5, 1.5], dtype=torch.float64))
tensor([[0.5000, 1.0000],
        [2.5000, 3.0000]], dtype=torch.float64)
>>> lut(x=3.0)                                  # clamped to the last node
tensor([4., 4.], dtype=torch.float64)
>>> lut(x=3.0, extrapolate="linear")            # slope of the edge cell [1, 2]
tensor([7., 6.], dtype=torch.float64)
"""

from __future__ import annotations

import copy
import hashlib
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import torch

from . import _checks
from ._io import atomic_write
from ._lut_file import (_FLOAT_DTYPES, _FORMAT_TAG, _RESERVED_AXIS_NAMES, _SAVABLE, EXPECT_KEYS,  # noqa: F401
                        EXTRAPOLATE_MODES, FORMAT_VERSION, _canonical_json, _current_version, _dtype_name,
                        _le_bytes, _normalise_json, check_expected, read_verified)

__all__ = ["LUT", "FORMAT_VERSION", "EXTRAPOLATE_MODES"]

def _tensor_version(t: torch.Tensor):
    try:
        return t._version
    except RuntimeError:  # inference tensors have no version counter
        return None


# ----------------------------------------------------------------------------- the LUT
class LUT:
    r"""Values on a regular-or-not rectilinear grid with named axes and provenance metadata.

    Args:
        values: real floating tensor (or array-like) of shape ``(n_1, ..., n_k, *C)``;
            kept as given (no copy), so gradients with respect to it flow through
            :meth:`interp`.  Treat it as immutable: the hash is cached per tensor version.
        axes: ordered mapping (or sequence of ``(name, grid)`` pairs) of ``k`` axes; each
            name a Python identifier (not ``"extrapolate"``), each grid 1-D, finite,
            strictly increasing, with ``n_i ≥ 2`` nodes; converted to the values'
            dtype/device (strict increase is checked after the conversion).
        builder: non-empty string saying what built the table (script path + function).
        parameters: JSON-serialisable dict of the builder's inputs (normalised through a
            JSON round trip: tuples become lists).  Default ``{}``.
        units: dict ``axis name or "values" → unit string``, e.g. ``{"omega": "nm"}``.
        torchirid_version: version that built the table; default: the running version
            (:meth:`read` passes the stored one).

    Raises:
        ValueError: naming the offending argument (axis not 1-D, not strictly increasing,
            NaN, length mismatch with ``values``, non-float values, bad metadata types...).

    Example:
        >>> import torch
        >>> w = torch.linspace(400.0, 700.0, 4, dtype=torch.float64)   # nm
        >>> lut = LUT(torch.stack([w, 2 * w], -1), {"omega": w}, builder="example",
        ...           units={"omega": "nm"})
        >>> lut(omega=torch.tensor([450.0], dtype=torch.float64))
        tensor([[450., 900.]], dtype=torch.float64)
        >>> lut.channel_shape, list(lut.axes)
        ((2,), ['omega'])
    """

    def __init__(self, values, axes, *, builder: str, parameters: Mapping[str, Any] | None = None,
                 units: Mapping[str, str] | None = None, torchirid_version: str | None = None):
        # --- values
        if isinstance(values, torch.Tensor):
            v = values
        else:
            if np.iscomplexobj(values):
                raise ValueError("values must be real, got complex data")
            try:
                v = torch.as_tensor(values)
            except (TypeError, ValueError, RuntimeError) as e:
                raise ValueError(f"values must be a real floating tensor: {e}") from None
        if v.dtype not in _FLOAT_DTYPES:
            raise ValueError(
                f"values must be a real floating tensor (float16/bfloat16/float32/float64), "
                f"got dtype {_dtype_name(v.dtype)}"
            )
        # --- axes
        if isinstance(axes, Mapping):
            items = list(axes.items())
        else:
            try:
                items = [tuple(p) for p in axes]
            except TypeError:
                raise ValueError("axes must be a mapping name → 1-D grid") from None
            if any(len(p) != 2 for p in items):
                raise ValueError("axes must be a mapping name → 1-D grid, or (name, grid) pairs")
        if not items:
            raise ValueError("axes must hold at least one axis")
        if len(items) > v.dim():
            raise ValueError(
                f"values has {v.dim()} dims but {len(items)} axes were given; values shape "
                f"must be (len(axis_1), ..., len(axis_k), *channels)"
            )
        ax: dict[str, torch.Tensor] = {}
        for i, (name, grid) in enumerate(items):
            if not isinstance(name, str) or not name.isidentifier():
                raise ValueError(f"axis names must be Python identifiers, got {name!r}")
            if name in _RESERVED_AXIS_NAMES:
                raise ValueError(f"axis name {name!r} is reserved (a keyword of LUT.interp)")
            if name in ax:
                raise ValueError(f"axis {name!r} given twice")
            ax[name] = self._check_axis(name, grid, v.dtype, v.device, v.shape[i])
        # --- metadata
        if not isinstance(builder, str) or not builder:
            raise ValueError(f"builder must be a non-empty string, got {builder!r}")
        if parameters is None:
            parameters = {}
        if not isinstance(parameters, Mapping):
            raise ValueError(f"parameters must be a dict, got {type(parameters).__name__}")
        params = _normalise_json(dict(parameters), "parameters")
        if units is None:
            units = {}
        if not isinstance(units, Mapping):
            raise ValueError(f"units must be a dict, got {type(units).__name__}")
        valid_unit_keys = list(ax) + ["values"]
        for key, unit in units.items():
            if key not in valid_unit_keys:
                raise ValueError(f"units key {key!r} is neither an axis nor 'values' "
                                 f"(valid: {valid_unit_keys})")
            if not isinstance(unit, str):
                raise ValueError(f"units[{key!r}] must be a string, got {type(unit).__name__}")
        if torchirid_version is None:
            torchirid_version = _current_version()
        if not isinstance(torchirid_version, str):
            raise ValueError(f"torchirid_version must be a string, got {torchirid_version!r}")

        self._values = v
        self._axes = ax
        self._builder = builder
        self._parameters = params
        self._units = dict(units)
        self._version = torchirid_version
        self._hash_cache: tuple | None = None

    @staticmethod
    def _check_axis(name, grid, dtype, device, size) -> torch.Tensor:
        if isinstance(grid, torch.Tensor):
            g = grid
        else:
            if np.iscomplexobj(grid):
                raise ValueError(f"axis {name!r} must be real, got complex data")
            try:
                g = torch.as_tensor(grid)
            except (TypeError, ValueError, RuntimeError) as e:
                raise ValueError(f"axis {name!r} must be a 1-D real tensor: {e}") from None
        if g.is_complex() or g.dtype == torch.bool:
            raise ValueError(f"axis {name!r} must be real, got dtype {_dtype_name(g.dtype)}")
        if g.dim() != 1:
            raise ValueError(f"axis {name!r} must be 1-D, got shape {tuple(g.shape)}")
        if g.numel() != size:
            raise ValueError(
                f"axis {name!r} has {g.numel()} nodes but values has {size} along that dim"
            )
        if g.numel() < 2:
            raise ValueError(f"axis {name!r} needs at least 2 nodes, got {g.numel()}")
        g = g.to(dtype=dtype, device=device)
        if not bool(torch.isfinite(g).all()):
            raise ValueError(f"axis {name!r} contains NaN or infinite coordinates")
        if not bool((g[1:] > g[:-1]).all()):
            raise ValueError(
                f"axis {name!r} must be strictly increasing (in {_dtype_name(dtype)})"
            )
        return g

    # ------------------------------------------------------------------ properties
    @property
    def values(self) -> torch.Tensor:
        """The table, shape ``(n_1, ..., n_k, *channels)`` (the tensor itself, not a copy)."""
        return self._values

    @property
    def axes(self) -> dict[str, torch.Tensor]:
        """Ordered ``{name: grid}`` (a new dict; the grids are the stored tensors)."""
        return dict(self._axes)

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(self._axes)

    @property
    def channel_shape(self) -> tuple[int, ...]:
        """The trailing channel dims ``C`` of ``values`` (``()`` for a scalar table)."""
        return tuple(self._values.shape[len(self._axes):])

    @property
    def dtype(self) -> torch.dtype:
        return self._values.dtype

    @property
    def device(self) -> torch.device:
        return self._values.device

    @property
    def builder(self) -> str:
        return self._builder

    @property
    def parameters(self) -> dict:
        return copy.deepcopy(self._parameters)

    @property
    def units(self) -> dict[str, str]:
        return dict(self._units)

    @property
    def torchirid_version(self) -> str:
        return self._version

    def _meta_without_hash(self) -> dict:
        return {
            "format": _FORMAT_TAG,
            "format_version": FORMAT_VERSION,
            "builder": self._builder,
            "parameters": copy.deepcopy(self._parameters),
            "units": dict(self._units),
            "torchirid_version": self._version,
            "axes": list(self._axes),
            "shape": list(self._values.shape),
            "dtype": _dtype_name(self._values.dtype),
        }

    @property
    def hash(self) -> str:
        """SHA-256 hex digest of metadata (without the hash) + axes bytes + values bytes."""
        key = (_tensor_version(self._values),
               tuple(_tensor_version(g) for g in self._axes.values()))
        cacheable = key[0] is not None and None not in key[1]
        if cacheable and self._hash_cache is not None and self._hash_cache[0] == key:
            return self._hash_cache[1]
        h = hashlib.sha256()
        h.update(_canonical_json(self._meta_without_hash()).encode("ascii"))
        for g in self._axes.values():
            h.update(_le_bytes(g))
        h.update(_le_bytes(self._values))
        digest = h.hexdigest()
        self._hash_cache = (key, digest) if cacheable else None
        return digest

    @property
    def meta(self) -> dict:
        """The metadata exactly as stored in a file (a fresh dict, ``hash`` included)."""
        m = self._meta_without_hash()
        m["hash"] = self.hash
        return m

    def __repr__(self) -> str:
        parts = []
        for name, g in self._axes.items():
            lo, hi = float(g[0]), float(g[-1])
            parts.append(f"{name}: {g.numel()} in [{lo:.6g}, {hi:.6g}]")
        return (f"LUT(axes=[{', '.join(parts)}], channels={self.channel_shape}, "
                f"dtype={_dtype_name(self.dtype)}, device={self.device}, "
                f"builder={self._builder!r})")

    def to(self, dtype: torch.dtype | None = None, device=None) -> "LUT":
        """A LUT with values and axes converted (differentiably) to ``dtype`` / ``device``.

        The metadata is kept; the hash is that of the converted content (it changes with
        the dtype).  Raises ValueError if ``dtype`` is not floating or if an axis stops
        being strictly increasing in the new dtype.
        """
        if dtype is not None and dtype not in _FLOAT_DTYPES:
            raise ValueError(f"dtype must be a floating dtype, got {dtype}")
        v = self._values.to(dtype=dtype or self.dtype, device=device or self.device)
        return LUT(v, {n: g.to(device=v.device) for n, g in self._axes.items()},
                   builder=self._builder, parameters=self._parameters, units=self._units,
                   torchirid_version=self._version)

    # ------------------------------------------------------------------ interpolation
    def _as_coord(self, c, name: str) -> torch.Tensor:
        if isinstance(c, bool) or (isinstance(c, torch.Tensor) and c.dtype == torch.bool):
            raise ValueError(f"coordinate {name!r} must be real, got a boolean")
        if isinstance(c, complex) or (isinstance(c, torch.Tensor) and c.is_complex()) \
                or (not isinstance(c, torch.Tensor) and np.iscomplexobj(c)):
            raise ValueError(f"coordinate {name!r} must be real, got complex data")
        try:
            return torch.as_tensor(c, dtype=self.dtype, device=self.device)
        except (TypeError, ValueError, RuntimeError) as e:
            raise ValueError(f"coordinate {name!r} must be a real tensor or number: {e}") from None

    def interp(self, /, *args, extrapolate: str = "clamp", **coords) -> torch.Tensor:
        r"""Multilinear interpolation at ``coords`` (one per axis, by name or in axis order).

        Args:
            *args: one coordinate per axis, in axis order (tensors, arrays or numbers, in
                the axis' units), all broadcasting together to a batch shape ``B``;
                converted to the LUT's dtype/device (differentiably).
            **coords: the same by axis name (instead of ``*args``).
            extrapolate: ``"clamp"`` (default: coordinates clamped to the grid, so the
                edge value is returned and the gradient is zero outside), ``"error"``
                (ValueError naming the axis and its range; NaN passes and propagates) or
                ``"linear"`` (linear continuation of the edge cell).

        Returns:
            tensor of shape ``B + channel_shape``, differentiable with respect to the
            coordinates and to ``values``.  Exact at the grid nodes; exact for functions
            that are affine in each variable (multilinear).  NaN coordinates give NaN.

        The cell is found with :func:`torch.searchsorted` (right-closed cells, so a node
        belongs to the cell on its right; the last node to the last cell), then the
        ``2^k`` corners are gathered in one indexing op and combined with :func:`torch.lerp`
        along each axis: no Python loop over points.

        Example:
            >>> import torch
            >>> a = torch.tensor([0.0, 1.0], dtype=torch.float64)
            >>> b = torch.tensor([0.0, 10.0, 20.0], dtype=torch.float64)
            >>> lut = LUT(a[:, None] + b[None, :], {"a": a, "b": b}, builder="doc")
            >>> lut.interp(a=torch.tensor([[0.25], [0.5]], dtype=torch.float64),
            ...            b=torch.tensor([5.0, 15.0], dtype=torch.float64))
            tensor([[ 5.2500, 15.2500],
                    [ 5.5000, 15.5000]], dtype=torch.float64)
        """
        _checks.check_choice(extrapolate, "extrapolate", EXTRAPOLATE_MODES)
        names = tuple(self._axes)
        if len(args) > len(names):
            raise ValueError(
                f"got {len(args)} positional coordinates for {len(names)} axes {names}"
            )
        given = dict(zip(names, args))
        for name, c in coords.items():
            if name not in self._axes:
                raise ValueError(f"unknown axis {name!r}; this LUT's axes are {names}")
            if name in given:
                raise ValueError(f"coordinate {name!r} given both positionally and by name")
            given[name] = c
        missing = [n for n in names if n not in given]
        if missing:
            raise ValueError(f"missing coordinate(s) {missing}; this LUT's axes are {names}")
        xs = [self._as_coord(given[n], n) for n in names]
        try:
            xs = list(torch.broadcast_tensors(*xs))
        except RuntimeError as e:
            shapes = {n: tuple(x.shape) for n, x in zip(names, xs)}
            raise ValueError(f"coordinate shapes {shapes} do not broadcast: {e}") from None

        nc = len(self.channel_shape)
        idxs, ts = [], []
        for name, x in zip(names, xs):
            g = self._axes[name]
            if extrapolate == "error":
                outside = (x < g[0]) | (x > g[-1])  # NaN compares False: it propagates
                if bool(outside.any()):
                    bad = x.detach()[outside]
                    raise ValueError(
                        f"coordinate {name!r} outside the LUT range [{float(g[0]):.6g}, "
                        f"{float(g[-1]):.6g}]: found values in [{float(bad.min()):.6g}, "
                        f"{float(bad.max()):.6g}] (use extrapolate='clamp' or 'linear')"
                    )
            elif extrapolate == "clamp":
                x = torch.clamp(x, g[0], g[-1])  # zero gradient outside, edge value returned
            i = self._cell(name, g, x.detach())
            g0, g1 = g[i], g[i + 1]
            t = (x - g0) / (g1 - g0)
            idxs.append(i)
            ts.append(t.reshape(t.shape + (1,) * nc))

        v = self._values
        if len(names) == 1:  # fast common path: cumulative 1-D tables
            i = idxs[0]
            return torch.lerp(v[i], v[i + 1], ts[0])

        k = len(names)
        table_shape = v.shape[:k]
        strides = [math.prod(table_shape[j + 1:]) for j in range(k)]
        base = sum(i * s for i, s in zip(idxs, strides))
        # corner c = (b_0 .. b_{k-1}) in binary, axis 0 most significant
        offsets = torch.tensor(
            [sum(((c >> (k - 1 - j)) & 1) * strides[j] for j in range(k)) for c in range(2 ** k)],
            dtype=base.dtype, device=base.device,
        )
        flat_idx = base.unsqueeze(0) + offsets.reshape((-1,) + (1,) * base.dim())
        corners = v.reshape((-1,) + self.channel_shape)[flat_idx]  # (2^k, *B, *C)
        corners = corners.reshape((2,) * k + corners.shape[1:])
        for j in reversed(range(k)):  # reduce the last corner dim with axis j's weight
            corners = torch.lerp(corners.select(j, 0), corners.select(j, 1), ts[j])
        return corners

    __call__ = interp

    def _cell(self, name, g, x):
        """Index of the cell ``[g[i], g[i+1])`` holding ``x`` (right-closed: a node belongs to
        the cell on its right, the last node to the last cell), clamped to the edge cells.

        Uniform axes (the common case: tables uniform in their variable) get the index by
        arithmetic with a one-step correction for rounding; others by :func:`torch.searchsorted`.
        Both give the same cells.
        """
        n = g.numel()
        step = self._uniform_steps().get(name)
        if step is None or n < 3:
            return (torch.searchsorted(g, x.contiguous(), right=True) - 1).clamp(0, n - 2)
        pos = torch.nan_to_num((x - g[0]) / step, nan=0.0, posinf=n, neginf=-1.0)
        i = torch.floor(pos).clamp(0, n - 2).to(torch.long)
        i = torch.where((x >= g[(i + 1).clamp(max=n - 1)]) & (i < n - 2), i + 1, i)  # rounding, one step
        return torch.where((x < g[i]) & (i > 0), i - 1, i)

    def _uniform_steps(self):
        """{axis: step} for the axes whose nodes are equally spaced (to 1e-9 of the step)."""
        cached = getattr(self, "_steps_cache", None)
        if cached is None:
            cached = {}
            for name, g in self._axes.items():
                if g.numel() >= 3:
                    d = g[1:] - g[:-1]
                    h = (g[-1] - g[0]) / (g.numel() - 1)
                    if bool((d - h).abs().max() <= 1e-9 * h.abs()):
                        cached[name] = float(h)
            self._steps_cache = cached
        return cached

    # ------------------------------------------------------------------ I/O
    def write(self, path) -> Path:
        """Write the LUT to ``path`` (suffix ``.npz``) atomically; returns the path.

        The file layout is described in the module docstring: plain numeric arrays only
        (``np.savez``, no pickle), the metadata as a UTF-8 JSON ``uint8`` array.  The data
        are written to a temporary file in the target's directory, flushed and fsynced,
        then moved onto ``path`` with :func:`os.replace`; on any failure the temporary file
        is removed and an existing file at ``path`` is left untouched.  float16/32/64 are
        stored as such; bfloat16 has no numpy dtype (ValueError: convert with ``.to``).
        Only ``.npz`` is supported for now (safetensors could be added later if needed).
        """
        path = Path(path)
        if path.suffix.lower() != ".npz":
            raise ValueError(f"LUT files must have the '.npz' suffix, got {str(path)!r}")
        if self.dtype not in _SAVABLE:
            raise ValueError(f"cannot save {_dtype_name(self.dtype)} values (no numpy dtype); "
                             f"use lut.to(torch.float32).write(...)")
        meta_bytes = _canonical_json(self.meta).encode("ascii")
        arrays = {"values": self._values.detach().to("cpu").contiguous().numpy()}
        for j, g in enumerate(self._axes.values()):
            arrays[f"axis_{j}"] = g.detach().to("cpu").contiguous().numpy()
        arrays["meta"] = np.frombuffer(meta_bytes, dtype=np.uint8)

        return atomic_write(path, lambda f: np.savez(f, **arrays))

    @classmethod
    def read(cls, path, *, builder: str | None = None, parameters: Mapping[str, Any] | None = None,
             expect: Mapping[str, Any] | None = None, dtype: torch.dtype | None = None,
             device=None) -> "LUT":
        """Read a LUT written by :meth:`write`, verify it, and check it is the expected one.

        Args:
            path: the ``.npz`` file.
            builder: if given, the stored builder must equal it.
            parameters: if given, every key must be stored with an equal value (subset
                match; values compared after a JSON round trip, so tuples equal lists).
            expect: further checks, keys among ``"axes"`` (axis names, in order),
                ``"channels"`` (channel shape) and ``"units"`` (subset match).
            dtype, device: convert after verification (default: as stored, on the CPU).

        Raises:
            FileNotFoundError: no file at ``path``.
            ValueError: unreadable/truncated/garbage file (message names the path and says
                corrupt), content hash mismatch ("corrupted: content hash mismatch"),
                unsupported format version, or a builder/parameters/axes/channels/units
                mismatch (message names the field, the expected and the found values).
        """
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"no LUT file at {str(path)!r}")
        if expect is not None:
            unknown = set(expect) - set(EXPECT_KEYS)
            if unknown:
                raise ValueError(f"unknown expect key(s) {sorted(unknown)}; valid: {EXPECT_KEYS}")

        lut = read_verified(cls, path)
        check_expected(lut, path, builder, parameters, expect)
        if dtype is not None or device is not None:
            lut = lut.to(dtype=dtype, device=device)
        return lut
