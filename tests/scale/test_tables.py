"""Chunked, resumable table builds (issue 24.1): in process, on a LocalCluster of 2 worker
processes, interrupted and resumed, and the errors at the edges."""

from __future__ import annotations

import time

import numpy as np
import pytest
import torch

import torchirid as ti

pytest.importorskip("zarr", reason="torchirid.scale needs zarr (the scale extra)")
from torchirid.scale import build_table, read_table, open_table  # noqa: E402

F64 = torch.float64
AXES = {"wavelength": np.linspace(400.0, 700.0, 31), "thickness": np.linspace(100.0, 500.0, 9)}
KWARGS = {"cos_theta": 0.8, "n_film": 1.33, "n_substrate": 1.5}


def _direct():
    return ti.thin_film_reflectance(torch.tensor(AXES["wavelength"])[:, None], 0.8, 1.33,
                                    torch.tensor(AXES["thickness"]), 1.5)


def test_in_process_build_is_the_function_on_the_grid(tmp_path):
    b = build_table(ti.thin_film_reflectance, AXES, tmp_path / "t.zarr", chunks={"wavelength": 8, "thickness": 4},
                    kwargs=KWARGS, units={"wavelength": "nm", "thickness": "nm", "values": "1"})
    assert (b.computed, b.skipped) == (12, 0)
    lut = read_table(tmp_path / "t.zarr")
    assert list(lut.axes) == ["wavelength", "thickness"] and lut.units["wavelength"] == "nm"
    assert "thin_film_reflectance" in lut.builder and lut.parameters["kwargs"] == KWARGS
    torch.testing.assert_close(lut.values, _direct(), rtol=0, atol=1e-15)
    arr, axes = open_table(tmp_path / "t.zarr")
    assert arr.chunksize == (8, 4) and np.array_equal(axes["thickness"], AXES["thickness"])
    np.testing.assert_array_equal(arr.compute(), lut.values.numpy())


def test_xyz_channels(tmp_path):
    axes = {"cos_theta": np.linspace(0.2, 1.0, 5), "d1": np.linspace(100.0, 140.0, 3)}
    build_table(ti.bragg_xyz, axes, tmp_path / "x.zarr", chunks=2, channels=(3,),
                kwargs={"n1": 1.0, "n2": 1.5, "d2": 375.0, "cells": 20, "method": "envelope"})
    lut = read_table(tmp_path / "x.zarr")
    ref = ti.bragg_xyz(torch.tensor(axes["cos_theta"])[:, None], 1.0, 1.5, torch.tensor(axes["d1"]), 375.0, 20,
                       method="envelope")
    assert lut.values.shape == (5, 3, 3)
    torch.testing.assert_close(lut.values, ref, rtol=0, atol=1e-15)


def test_interrupted_build_resumes_only_missing_chunks(tmp_path):
    store = tmp_path / "t.zarr"

    def stop_after_five(done, total):
        if done >= 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        build_table(ti.thin_film_reflectance, AXES, store, chunks=4, kwargs=KWARGS, progress=stop_after_five)
    with pytest.raises(ValueError, match="unfinished"):
        read_table(store)
    seen = []
    b = build_table(ti.thin_film_reflectance, AXES, store, chunks=4, kwargs=KWARGS,
                    progress=lambda d, t: seen.append((d, t)))
    assert (b.computed, b.skipped) == (24 - 5, 5) and seen[0] == (5, 24) and seen[-1] == (24, 24)
    torch.testing.assert_close(read_table(store).values, _direct(), rtol=0, atol=1e-15)


def test_a_different_build_is_refused(tmp_path):
    store = tmp_path / "t.zarr"
    build_table(ti.thin_film_reflectance, AXES, store, chunks=16, kwargs=KWARGS)
    with pytest.raises(ValueError, match="different table build"):
        build_table(ti.thin_film_reflectance, AXES, store, chunks=16, kwargs={**KWARGS, "n_film": 1.4})


@pytest.mark.parametrize("bad, match", [
    (dict(axes={}), "axes"),
    (dict(axes={"wavelength": [[1.0]]}), "1-D"),
    (dict(chunks=0), "chunks"),
    (dict(kwargs={"cos_theta": object()}), "JSON"),
    (dict(kwargs={"wavelength": 1.0}), "both name"),
    (dict(channels=3), "channels"),
])
def test_bad_arguments(tmp_path, bad, match):
    args = dict(axes=AXES, chunks=8, kwargs=KWARGS, channels=())
    args.update(bad)
    with pytest.raises(ValueError, match=match):
        build_table(ti.thin_film_reflectance, args["axes"], tmp_path / "t.zarr", chunks=args["chunks"],
                    kwargs=args["kwargs"], channels=args["channels"])
    with pytest.raises(ValueError, match="module-level"):
        build_table(lambda **k: 0, AXES, tmp_path / "u.zarr")
    with pytest.raises(ValueError, match="progress"):
        build_table(ti.thin_film_reflectance, AXES, tmp_path / "v.zarr", kwargs=KWARGS, progress="bar")


def test_bad_scheduler_address_fails_fast(tmp_path):
    pytest.importorskip("distributed", reason="needs dask.distributed")
    t = time.perf_counter()
    with pytest.raises(OSError, match="no Dask scheduler"):
        build_table(ti.thin_film_reflectance, AXES, tmp_path / "t.zarr", chunks=8, kwargs=KWARGS,
                    scheduler="tcp://127.0.0.1:9", timeout=2.0)
    assert time.perf_counter() - t < 15


def test_local_cluster_equals_in_process(tmp_path):
    """2 worker processes: the same bits as the in-process build."""
    pytest.importorskip("distributed", reason="needs dask.distributed")
    build_table(ti.thin_film_reflectance, AXES, tmp_path / "a.zarr", chunks=4, kwargs=KWARGS)
    b = build_table(ti.thin_film_reflectance, AXES, tmp_path / "b.zarr", chunks=4, kwargs=KWARGS,
                    scheduler="local", workers=2)
    assert b.computed == 24
    assert torch.equal(read_table(tmp_path / "a.zarr").values, read_table(tmp_path / "b.zarr").values)


def test_bad_calls_are_refused_before_anything_is_written(tmp_path):
    store = tmp_path / "t.zarr"
    with pytest.raises(ValueError, match="missing"):
        build_table(ti.thin_film_reflectance, AXES, store, chunks=16, kwargs={"cos_theta": 0.8})
    with pytest.raises(ValueError, match="thickness"):
        build_table(ti.thin_film_reflectance, {**AXES, "thickness": [-1.0, 2.0]}, store, kwargs=KWARGS)
    with pytest.raises(ValueError, match=r"trailing output shape \(\)"):
        build_table(ti.thin_film_reflectance, AXES, store, kwargs=KWARGS, channels=(3,))
    assert not store.exists()
    b = build_table(ti.thin_film_reflectance, AXES, store, chunks=16, kwargs=KWARGS)
    assert b.computed == 2


def test_cli_build_table_and_resume(tmp_path, capsys):
    from torchirid.app.cli import main

    argv = ["build-table", "thin_film_reflectance", "--axis", "wavelength=400:700:31", "--axis", "thickness=100:500:9",
            "--set", "cos_theta=0.8", "--set", "n_film=1.33", "--set", "n_substrate=1.5", "--chunks", "8",
            "--out", str(tmp_path / "t.zarr"), "--quiet"]
    assert main(argv) == 0
    assert "8 chunks computed, 0 found done" in capsys.readouterr().out
    assert main(argv) == 0
    assert "0 chunks computed, 8 found done" in capsys.readouterr().out
    torch.testing.assert_close(read_table(tmp_path / "t.zarr").values, _direct(), rtol=0, atol=1e-15)
    with pytest.raises(SystemExit) as e:
        main(argv[:2] + ["--axis", "wavelength=400:700:5", "--set", "bogus=1", "--out", str(tmp_path / "u.zarr")])
    assert e.value.code == 2 and "bogus" in capsys.readouterr().err


def test_a_worker_lost_mid_build_costs_only_its_chunks(tmp_path):
    """One of 2 worker processes is killed after the first chunk lands; Dask reschedules its
    chunks and the table equals the in-process build bit for bit."""
    import os
    import signal

    distributed = pytest.importorskip("distributed", reason="needs dask.distributed")
    axes = {"cos_theta": np.linspace(0.3, 1.0, 12), "d1": np.linspace(100.0, 140.0, 8)}
    kwargs = {"n1": 1.0, "n2": 1.5, "d2": 375.0, "cells": 1000}  # spectral: ~0.1 s per chunk of 4 colours
    build_table(ti.bragg_xyz, axes, tmp_path / "ref.zarr", chunks=2, channels=(3,), kwargs=kwargs)
    killed = {}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        before = sorted(client.scheduler_info()["workers"])

        def progress(done, total):
            if done >= 1 and not killed:
                nanny = next(n for n in cluster.workers.values() if n.worker_address == before[0])
                killed.update(address=before[0], done=done, total=total)
                os.kill(nanny.process.pid, signal.SIGKILL)  # the worker process dies mid-task

        b = build_table(ti.bragg_xyz, axes, tmp_path / "t.zarr", chunks=2, channels=(3,), kwargs=kwargs,
                        client=client, progress=progress)
        after = set(client.scheduler_info()["workers"])
    assert killed and killed["done"] < killed["total"] - 4, killed  # the kill came with chunks left
    assert killed["address"] not in after
    assert b.computed == 24
    assert torch.equal(read_table(tmp_path / "t.zarr").values, read_table(tmp_path / "ref.zarr").values)
