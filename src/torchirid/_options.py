"""The library's configuration: one function, :func:`torchirid.options`, as getter, setter and context manager."""

from __future__ import annotations

from . import _checks, _chunks, _compile, _threads

__all__ = ["options"]


def _bool(name):
    def check(value):
        if not isinstance(value, bool):
            raise ValueError(f"{name} must be True or False; got {value!r}")
        return value

    return check


def _chunk(value):
    if value is None or value == _chunks.AUTO:
        return value
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"chunk_size must be an int >= 1 (points per block), 0 / None for no chunking, or "
                         f"'auto' (the default per device); got {value!r}")
    return value or None


def _threads_count(value):
    if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 0):
        raise ValueError(f"small_work_threads must be an int >= 1, or 0 / None to leave torch's setting; "
                         f"got {value!r}")
    return value or None


def _large_threads(value):
    if value == "auto" or value is None:
        return value
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"large_work_threads must be 'auto' (the cores other processes leave free), an int >= 1, "
                         f"or 0 / None to leave torch's setting; got {value!r}")
    return value or None


#: option name → (check, read the current value, set a value)
_OPTIONS = {
    "value_checks": (_bool("value_checks"), lambda: _checks._VALUE_CHECKS["enabled"],
                     lambda v: _checks._VALUE_CHECKS.__setitem__("enabled", v)),
    "chunk_size": (_chunk, lambda: _chunks._STATE["points"], lambda v: _chunks._STATE.__setitem__("points", v)),
    "small_work_threads": (_threads_count, lambda: _threads._STATE["threads"],
                           lambda v: _threads._STATE.__setitem__("threads", v)),
    "large_work_threads": (_large_threads, lambda: _threads._STATE["large"],
                           lambda v: _threads._STATE.__setitem__("large", v)),
    "compile": (_bool("compile"), lambda: _compile._state["enabled"],
                lambda v: _compile._state.__setitem__("enabled", v)),
}


def _unknown(name):
    return ValueError(f"unknown option {name!r}; the options are {_checks.names(_OPTIONS)}")


class _Options(dict):
    """The options after a call to :func:`options` (a dict); as a context manager it restores
    the values it changed on exit."""

    def __init__(self, before):
        super().__init__({name: read() for name, (_, read, _) in _OPTIONS.items()})
        self._before = before

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        for name, value in self._before.items():
            _OPTIONS[name][2](value)
        return False


def options(name: str | None = None, /, **changes):
    """Read or set the library's options.

    - ``options("chunk_size")``: the current value of one option;
    - ``options()``: every option, as a dict;
    - ``options(chunk_size=4096, value_checks=False)``: set options for the whole process and
      return them all; used as a ``with`` statement, the changed options get their previous
      values back on exit.

    Five process-wide switches, each also settable from the environment at import:

    ========================  =====================================  ==============================
    option                    values (default first)                 environment variable
    ========================  =====================================  ==============================
    ``value_checks``          ``True``, ``False``                    —
    ``chunk_size``            ``"auto"``, an int ≥ 1, ``None``       ``TORCHIRID_CHUNK_SIZE``
    ``small_work_threads``    ``1``, an int ≥ 1, ``None``            ``TORCHIRID_SMALL_WORK_THREADS``
    ``large_work_threads``    ``"auto"``, an int ≥ 1, ``None``       ``TORCHIRID_LARGE_WORK_THREADS``
    ``compile``               ``False``, ``True``                    ``TORCHIRID_COMPILE``
    ========================  =====================================  ==============================

    - ``value_checks``: check argument *values* (wavelength in nm, cos θ in [0, 1], Re n > 0, κ ≥ 0,
      thickness ≥ 0, ...) and raise ValueError. The checks read tensors back to Python, which
      ``torch.func.vmap`` cannot do: run vmapped code with the checks off (invalid values then give
      NaN or wrong numbers). Types, shapes, option names and dtypes are always checked; under
      ``torch.compile`` the value checks step aside by themselves.
    - ``chunk_size``: points per block when a table-producing function evaluates a large batch
      block by block (no gradient wanted). ``"auto"``: 32 768 points on the CPU, 2²⁴ on
      accelerators; ``None`` (or 0): one piece. Results equal the one-piece evaluation to a few ulp.
    - ``small_work_threads``: torch threads for calls whose work is below 32 768 elements (the
      measured policy: docs/performance.md, "Threads on a shared machine"); ``None`` (or 0): leave
      torch's thread count alone.
    - ``large_work_threads``: torch threads for larger calls (tables, colour integrals, the film
      estimation, the scatterogram match, texture fits). ``"auto"``: the cores that other processes
      leave free, measured from the system's CPU time since the previous large call (all of the
      caller's threads on a quiet machine, one beside a busy process on two cores); an int: at most
      that many; ``None`` (or 0): torch's count. Never more than the caller's
      ``torch.get_num_threads()``.
    - ``compile``: ``torch.compile`` the elementwise kernels of large calls (a C++ compiler and
      seconds per kernel variant on first use; values agree with the eager kernels to ~1e-13).

    Raises:
        ValueError: an unknown option name (listing the valid ones) or an invalid value (nothing
            is changed then).

    >>> import torchirid
    >>> torchirid.options()
    {'value_checks': True, 'chunk_size': 'auto', 'small_work_threads': 1, 'large_work_threads': 'auto', 'compile': False}
    >>> with torchirid.options(value_checks=False, chunk_size=4096):
    ...     torchirid.options("chunk_size")
    4096
    >>> torchirid.options("chunk_size")  # restored on exit
    'auto'
    """
    if name is not None:
        if changes:
            raise ValueError("options(name) reads one option; set options by keyword: options(chunk_size=4096)")
        if name not in _OPTIONS:
            raise _unknown(name)
        return _OPTIONS[name][1]()
    checked = {}
    for key, value in changes.items():
        if key not in _OPTIONS:
            raise _unknown(key)
        checked[key] = _OPTIONS[key][0](value)
    before = {key: _OPTIONS[key][1]() for key in checked}
    for key, value in checked.items():
        _OPTIONS[key][2](value)
    return _Options(before)
