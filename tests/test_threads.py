"""The thread policy: calls below torchirid._threads.SMALL_WORK elements run with one torch thread
and restore the caller's count; large calls run with the cores other processes leave free (measured:
the tests set the measurement), at most the caller's count; the switched-off policies leave it alone."""

from __future__ import annotations

import pytest
import torch

import torchirid as ti
import torchirid._chunks as chunks
from torchirid import _threads

F64 = torch.float64


@pytest.fixture
def two_threads(monkeypatch):
    """Two torch threads on a two-core machine that the tests call quiet (no other process busy)."""
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    monkeypatch.setattr(_threads, "_cores", lambda: 2)
    monkeypatch.setattr(_threads, "other_load", lambda: 0.0)
    yield
    torch.set_num_threads(before)
    ti.options(small_work_threads=1, large_work_threads="auto")


def _threads_seen_by_kernel(monkeypatch, call):
    seen = []
    real = chunks.evaluate

    def spy(kernel, *args, **kwargs):
        def wrapped(*a, **k):
            seen.append(torch.get_num_threads())
            return kernel(*a, **k)
        return real(wrapped, *args, **kwargs)

    monkeypatch.setattr(chunks, "evaluate", spy)
    call()
    return seen


def test_small_calls_run_on_one_thread_and_restore(two_threads, monkeypatch):
    lam = torch.linspace(400.0, 700.0, 31, dtype=F64)
    seen = _threads_seen_by_kernel(monkeypatch, lambda: ti.thin_film_reflectance(lam, 0.8, 1.33, 300.0, 1.5))
    assert seen == [1]
    assert torch.get_num_threads() == 2


def test_large_calls_keep_the_callers_threads(two_threads, monkeypatch):
    lam = torch.linspace(400.0, 700.0, 401, dtype=F64)
    c = torch.linspace(0.1, 1.0, 90, dtype=F64)[:, None]  # 36 090 points ≥ SMALL_WORK
    seen = _threads_seen_by_kernel(monkeypatch, lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5))
    assert seen and set(seen) == {2}


def test_policy_off_and_bragg_xyz(two_threads, monkeypatch):
    ti.options(small_work_threads=None)
    lam = torch.linspace(400.0, 700.0, 31, dtype=F64)
    assert _threads_seen_by_kernel(monkeypatch, lambda: ti.thin_film_reflectance(lam, 0.8, 1.33, 300.0, 1.5)) == [2]
    ti.options(small_work_threads=1)
    inside = []
    real = torch.Tensor.__matmul__
    monkeypatch.setattr(torch.Tensor, "__matmul__", lambda a, b: inside.append(torch.get_num_threads()) or real(a, b))
    ti.bragg_xyz(torch.tensor(0.9, dtype=F64), 1.0, 1.5, 125.0, 375.0, 20)  # the colour integral too
    assert inside and set(inside) == {1}
    assert torch.get_num_threads() == 2


def test_nested_and_failing_blocks_restore(two_threads):
    with _threads.limited(10):
        assert torch.get_num_threads() == 1
        with _threads.limited(10):
            assert torch.get_num_threads() == 1
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == 2
    with pytest.raises(RuntimeError):
        with _threads.limited(10):
            raise RuntimeError("boom")
    assert torch.get_num_threads() == 2
    with _threads.limited(_threads.SMALL_WORK):
        assert torch.get_num_threads() == 2


def test_knob_validation():
    for bad in (-1, 1.5, True, "1"):
        with pytest.raises(ValueError, match="threads"):
            ti.options(small_work_threads=bad)
    ti.options(small_work_threads=0)
    assert ti.options("small_work_threads") is None
    ti.options(small_work_threads=1)
    assert ti.options("small_work_threads") == 1


def test_large_work_takes_the_free_cores(two_threads, monkeypatch):
    import math

    load = {"others": 1.0}  # one busy process beside us on two cores
    monkeypatch.setattr(_threads, "other_load", lambda: load["others"])
    monkeypatch.setattr(_threads, "SAMPLE_S", 0.0)  # (re-decide at every small call, not every 0.2 s)
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == 2
    load["others"] = 0.3  # rounds to no core taken
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 2
        load["others"] = 1.2  # the neighbour starts during the fit: its next small call gives back 1
        with _threads.limited(10):
            assert torch.get_num_threads() == 1
        assert torch.get_num_threads() == 1
        load["others"] = 0.0  # and leaves: the next small call gives back both
        with _threads.limited(10):
            assert torch.get_num_threads() == 1
        assert torch.get_num_threads() == 2
    assert torch.get_num_threads() == 2
    load["others"] = 5.0  # never fewer than one thread
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == 2


def test_large_work_knob(two_threads, monkeypatch):
    import math

    monkeypatch.setattr(_threads, "other_load", lambda: 1.0)
    ti.options(large_work_threads=None)  # torch's count
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 2
    ti.options(large_work_threads=1)
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 1
    ti.options(large_work_threads=8)  # never more than the caller's
    with _threads.limited(math.inf):
        assert torch.get_num_threads() == 2
    for bad in (-1, 1.5, True, "two"):
        with pytest.raises(ValueError, match="large_work_threads"):
            ti.options(large_work_threads=bad)
    assert ti.options("large_work_threads") == 8
    ti.options(large_work_threads="auto")


def test_busy_elsewhere_is_the_system_minus_this_process():
    # (wall s, system busy CPU s, this process's CPU s)
    assert _threads.busy_elsewhere((0.0, 10.0, 1.0), (1.0, 12.0, 2.0)) == pytest.approx(1.0)
    assert _threads.busy_elsewhere((0.0, 10.0, 1.0), (2.0, 11.0, 2.0)) == 0.0  # (never negative)
    assert _threads.busy_elsewhere((1.0, 0.0, 0.0), (1.0, 5.0, 0.0)) == 0.0  # (no wall time)
    sample = _threads._sample()
    if sample is None:
        pytest.skip("no /proc/stat here: the policy leaves the thread count alone")
    assert len(sample) == 3 and sample[1] >= 0 and sample[2] >= 0
    assert _threads.other_load() is None or _threads.other_load() >= 0


def test_the_heavy_workloads_run_as_large_work():
    from torchirid.estimation import estimate_film
    from torchirid.fitting import match_scatterogram
    from torchirid.realtime import fit_texture

    for fn in (estimate_film, match_scatterogram, fit_texture):
        layers = []
        while fn is not None:  # the decorators, outermost first
            layers.append(fn.__code__.co_names)
            fn = getattr(fn, "__wrapped__", None)
        assert any("limited" in names for names in layers)
