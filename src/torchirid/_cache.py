"""Every cache of the package registers here, so that :func:`torchirid.clear_caches` empties
them all (e.g. after changing a shipped table on disk, or to free memory).

Caches hold derived data only (tables built or loaded once, quadrature rules, material
tensors): clearing them never changes a result, only the time of the next call.
"""

from __future__ import annotations

import functools
from typing import Callable, TypeVar

__all__ = ["cached", "cache_dict", "clear_caches"]

_CLEARERS: list[Callable[[], None]] = []

F = TypeVar("F", bound=Callable)


def cached(maxsize: int | None = None) -> Callable[[F], F]:
    """``functools.lru_cache(maxsize)`` whose cache :func:`clear_caches` empties."""

    def wrap(fn: F) -> F:
        wrapped = functools.lru_cache(maxsize=maxsize)(fn)
        _CLEARERS.append(wrapped.cache_clear)
        return wrapped  # type: ignore[return-value]

    return wrap


def cache_dict() -> dict:
    """A plain dict used as a cache, registered so that :func:`clear_caches` empties it."""
    d: dict = {}
    _CLEARERS.append(d.clear)
    return d


def clear_caches() -> None:
    """Empty every cache of torchirid (tables, quadrature rules, material tensors).

    Results do not change; the next call that needs a table rebuilds or reloads it.

    >>> import torchirid
    >>> torchirid.clear_caches()
    """
    for clear in _CLEARERS:
        clear()
