"""Shipped tables: read the copy in ``src/torchirid/data/`` or build it (one policy for every loader)."""

from __future__ import annotations

import importlib.resources
import warnings

from .lut import LUT


def read_or_build(resource, build, *, what: str, script: str, **read) -> LUT:
    """The shipped table at ``resource`` (an :mod:`importlib.resources` path), read and verified by
    :meth:`LUT.read` with the keyword arguments ``read`` (builder, parameters, expect, ...); a
    missing file is built by ``build()``, and so is a corrupt or stale one — never used, with a
    RuntimeWarning naming ``what`` and the ``script`` that rebuilds it."""
    if resource.is_file():
        try:
            with importlib.resources.as_file(resource) as path:
                return LUT.read(path, **read)
        except ValueError as e:  # corrupt or stale: never use it, say so, build instead
            warnings.warn(f"{what}: ignoring the shipped table ({e}); building it in memory (rebuild it with "
                          f"{script})", RuntimeWarning, stacklevel=4)
    return build()
