"""torchirid.clear_caches(): every cache of the package registers with it, and clearing changes
no result."""

import torch

import torchirid
from torchirid import _cache, _quadrature
from torchirid.color import colorimetry
from torchirid.ibl import dfg


def test_clear_caches_empties_registered_caches_and_keeps_results():
    before = torchirid.ibl.shipped_dfg_lut()(torch.tensor([0.5], dtype=torch.float64),
                                            torch.tensor([0.3], dtype=torch.float64))
    xyz = torchirid.spectrum_to_xyz(torch.full((81,), 0.5, dtype=torch.float64),
                                    torch.linspace(380, 780, 81, dtype=torch.float64))
    _quadrature.gauss_legendre01(7, torch.float64, torch.device("cpu"))
    assert dfg._shipped.cache_info().currsize > 0
    assert colorimetry.weighted_cmfs_numpy.cache_info().currsize > 0
    assert len(_quadrature._GL_CACHE) > 0

    torchirid.clear_caches()

    assert dfg._shipped.cache_info().currsize == 0
    assert colorimetry.weighted_cmfs_numpy.cache_info().currsize == 0
    assert len(_quadrature._GL_CACHE) == 0
    after = torchirid.ibl.shipped_dfg_lut()(torch.tensor([0.5], dtype=torch.float64),
                                           torch.tensor([0.3], dtype=torch.float64))
    assert torch.equal(before, after)
    assert torch.equal(xyz, torchirid.spectrum_to_xyz(torch.full((81,), 0.5, dtype=torch.float64),
                                                      torch.linspace(380, 780, 81, dtype=torch.float64)))


def test_no_unregistered_lru_cache_in_the_library():
    """Caches go through torchirid._cache (so clear_caches reaches them), not functools directly."""
    import pathlib

    src = pathlib.Path(torchirid.__file__).parent
    offenders = [str(p.relative_to(src)) for p in src.rglob("*.py")
                 if p.name != "_cache.py" and ("functools.lru_cache" in p.read_text(encoding="utf-8")
                                                or "functools.cache(" in p.read_text(encoding="utf-8"))]
    assert offenders == []
    import importlib
    import pkgutil

    # the clearers register when their modules are imported: import them all (the count once
    # depended on which test files had run before in the same worker)
    for m in pkgutil.walk_packages(torchirid.__path__, "torchirid."):
        if not m.name.endswith("__main__"):
            importlib.import_module(m.name)
    assert len(_cache._CLEARERS) >= 20
