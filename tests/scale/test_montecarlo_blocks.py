"""Distributed Monte Carlo (issue 24.2): independent seeded blocks, merged in a fixed order —
the estimate and its standard error are bit-identical whatever runs the blocks."""

from __future__ import annotations

import pytest
import torch

from torchirid.layered import LayeredBragg, RoughBraggLayer, montecarlo_brdf
from torchirid.scale import montecarlo_brdf_blocks
from torchirid.scale.montecarlo import block_seeds, merge_moments

F64 = torch.float64
S = LayeredBragg([RoughBraggLayer(1.0, 1.5, 100.0, 100.0, 5, 0.2)], base_albedo=0.5)
WI = torch.tensor([[0.3, 0.0, 0.954], [0.0, 0.0, 1.0]], dtype=F64)
WI = WI / torch.linalg.vector_norm(WI, dim=-1, keepdim=True)
WO = torch.tensor([0.0, 0.2, 0.98], dtype=F64)
WO = WO / torch.linalg.vector_norm(WO)
LAM = torch.tensor([450.0, 550.0, 650.0], dtype=F64)
OPTS = dict(transmission="microfacet")


def test_merge_equals_one_pass_statistics():
    g = torch.Generator().manual_seed(3)
    x = torch.randn(1000, 4, generator=g, dtype=F64) * 1e3 + 1e6  # large offset: cancellation-prone
    parts = []
    for chunk in x.split([100, 250, 50, 600]):
        parts.append((float(chunk.shape[0]), chunk.mean(0), ((chunk - chunk.mean(0)) ** 2).sum(0)))
    n, mean, m2 = merge_moments(parts)
    assert n == 1000
    torch.testing.assert_close(mean, x.mean(0), rtol=1e-15, atol=0)
    torch.testing.assert_close(m2 / (n - 1), x.var(0), rtol=1e-12, atol=0)


def test_blocks_are_one_montecarlo_run_each_and_seeds_are_fixed():
    seeds = block_seeds(7, 4)
    assert seeds == block_seeds(7, 4) and len(set(seeds)) == 4 and block_seeds(8, 4) != seeds
    mean, err = montecarlo_brdf_blocks(LAM, WI, WO, S, samples=64, blocks=1, seed=7, **OPTS)
    ref_mean, ref_err = montecarlo_brdf(LAM, WI, WO, S, samples=64, seed=block_seeds(7, 1)[0], **OPTS)
    assert torch.equal(mean, ref_mean)
    torch.testing.assert_close(err, ref_err, rtol=1e-14, atol=0)


def test_estimate_is_consistent_with_a_single_run():
    mean, err = montecarlo_brdf_blocks(LAM, WI, WO, S, samples=512, blocks=8, seed=1, **OPTS)
    ref, ref_err = montecarlo_brdf(LAM, WI, WO, S, samples=512, seed=123, **OPTS)
    assert mean.shape == (2, 3) and bool((err > 0).all())
    assert bool(((mean - ref).abs() <= 5 * torch.sqrt(err ** 2 + ref_err ** 2)).all())


def test_bad_arguments():
    with pytest.raises(ValueError, match="blocks"):
        montecarlo_brdf_blocks(LAM, WI, WO, S, samples=64, blocks=0)
    with pytest.raises(ValueError, match="samples"):
        montecarlo_brdf_blocks(LAM, WI, WO, S, samples=6, blocks=4)
    with pytest.raises(ValueError, match="seed"):
        montecarlo_brdf_blocks(LAM, WI, WO, S, samples=64, blocks=2, seed=-1)
    with pytest.raises(ValueError, match="progress"):
        montecarlo_brdf_blocks(LAM, WI, WO, S, samples=64, blocks=2, progress=1)


def test_bit_identical_on_a_local_cluster():
    distributed = pytest.importorskip("distributed", reason="needs dask.distributed")
    from torchirid.scale import local_cluster

    here = montecarlo_brdf_blocks(LAM, WI, WO, S, samples=96, blocks=6, seed=5, **OPTS)
    seen = []
    with local_cluster(2) as cluster, distributed.Client(cluster) as client:
        there = montecarlo_brdf_blocks(LAM, WI, WO, S, samples=96, blocks=6, seed=5, client=client,
                                       progress=lambda d, t: seen.append((d, t)), **OPTS)
    assert torch.equal(here[0], there[0]) and torch.equal(here[1], there[1])
    assert seen[-1] == (6, 6)


def test_cli_montecarlo_in_process_and_on_a_local_cluster(tmp_path, capsys):
    """``torchirid montecarlo``: the blocks' estimate, the same bits in process and on 2 workers."""
    import json

    import numpy as np

    from torchirid.app.cli import main
    from torchirid.presets import jewel_beetle

    argv = ["montecarlo", "--preset", "red", "--incident", "20", "0", "--exit", "20", "180", "--exit", "40", "150",
            "--wavelengths", "450", "650", "3", "--samples", "64", "--blocks", "4", "--seed", "7", "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "a.json")]) == 0
    assert "2 direction pairs × 3 wavelengths, 64 paths each in 4 blocks" in capsys.readouterr().out
    a = json.loads((tmp_path / "a.json").read_text())
    assert np.array(a["brdf"]).shape == (2, 3) and a["settings"]["seed"] == 7
    wi = torch.tensor(a["wi"], dtype=F64).expand(2, 3)
    ref, err = montecarlo_brdf_blocks(torch.tensor(a["wavelength_nm"], dtype=F64), wi, torch.tensor(a["wo"], dtype=F64),
                                      jewel_beetle("red"), samples=64, blocks=4, seed=7)
    assert a["brdf"] == ref.tolist() and a["stderr"] == err.tolist()
    pytest.importorskip("distributed", reason="needs dask.distributed")
    assert main([*argv, "--scheduler", "local", "--workers", "2", "--out", str(tmp_path / "b.npz")]) == 0
    b = np.load(tmp_path / "b.npz")
    assert b["brdf"].tolist() == a["brdf"] and b["stderr"].tolist() == a["stderr"]
