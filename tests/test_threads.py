"""The small-work thread policy (issue 23.4): calls below torchirid._threads.SMALL_WORK elements
run with one torch thread and restore the caller's count; large calls and the switched-off policy
leave it alone."""

from __future__ import annotations

import pytest
import torch

import torchirid as ti
import torchirid._chunks as chunks
from torchirid import _threads

F64 = torch.float64


@pytest.fixture
def two_threads():
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    yield
    torch.set_num_threads(before)
    ti.options(small_work_threads=1)


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
