"""method="auto": the cheapest measured method that meets the tolerance."""

import numpy as np
import pytest
import torch

import torchirid as ti
from tensors import F64, t64
from torchirid.spectral.auto import choose_bragg_method


@pytest.mark.parametrize("tolerance", [0.5, 2.0])
def test_auto_meets_its_tolerance_on_random_mirrors(tolerance):
    rng = np.random.default_rng(4)
    c = torch.cos(torch.deg2rad(torch.linspace(0, 89, 30, dtype=F64)))
    errs = []
    for _ in range(12):
        n2, lam_, f, N = rng.uniform(1.2, 2.4), rng.uniform(150, 1000), rng.uniform(0.1, 0.9), int(rng.integers(1, 51))
        d1, d2 = f * lam_, (1 - f) * lam_
        ref = ti.xyz_to_lab(ti.bragg_xyz(c, 1.0, n2, d1, d2, N))
        got = ti.xyz_to_lab(ti.bragg_xyz(c, 1.0, n2, d1, d2, N, method="auto", tolerance=tolerance))
        errs.append(ti.color.delta_e_2000(got, ref))
    assert np.percentile(torch.cat(errs).numpy(), 95) <= tolerance


def test_choices_follow_the_measured_tables():
    c = t64([0.2, 0.7, 1.0])
    thin = choose_bragg_method(c, 1.0, 1.5, 0.0, 300.0, 1, tolerance=1.0)
    assert thin["config"] == {"method": "sampled", "samples": 64}  # a thin film: ~1 fringe
    # outside the approximations' setting (few cells; host ≠ n1) the sampled count scales with N
    few = choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 5, tolerance=1.0)["config"]
    many = choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 200, n_incident=1.33, tolerance=1.0)["config"]
    assert few["method"] == many["method"] == "sampled" and many["samples"] > 5 * few["samples"]
    # the envelope/piecewise cost does not grow with N: one of them wins for many cells (at the
    # benchmark's 810 colours per call; on 3 colours per call a short sampled integration wins)
    for N in (20, 200, 2000):
        chosen = choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, N, tolerance=1.0, batch_size=810)["config"]["method"]
        assert chosen in ("envelope", "piecewise")
    # not their setting (host ≠ n1): never an approximation
    assert choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 2000, n_incident=1.33,
                               tolerance=3.0)["config"]["method"] not in ("piecewise", "envelope")
    # tighter than anything measured but spectral: spectral
    assert choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 20, tolerance=0.005)["config"] == {"method": "spectral"}
    with pytest.raises(ValueError, match="tolerance"):
        choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 20, tolerance=0)


def test_error_table_names_its_builder_and_its_errors_reproduce():
    """data/bragg_color_errors.json is built by luts/build_bragg_color_errors.py (its provenance
    says so); its times are one machine's, but its errors are deterministic: recomputed here for
    four configurations at Λ = 244 nm of Fourneau's Fig. 4 grid (810 colours), they equal the
    table's (a change of any method's values shows up here)."""
    import json
    import warnings
    from pathlib import Path

    from torchirid.color import delta_e_2000, xyz_to_lab
    from torchirid.spectral import auto

    root = Path(__file__).resolve().parents[2]
    data = json.loads(auto._TABLE.read_text())
    builder = data["provenance"]["builder"]
    assert builder == "luts/build_bragg_color_errors.py" and (root / builder).is_file()
    assert data["provenance"]["command"].startswith(f"python {builder}")
    g = data["grids"]["fig4"]
    ref_spf = g["error_reference"]["samples_per_fringe"]
    cos = torch.cos(torch.deg2rad(torch.tensor(g["angles_deg"], dtype=F64)))
    period = 244.0
    d1 = (torch.tensor(g["d1_over_period"], dtype=F64) * period)[:, None]
    mirror = (cos, g["n1"], g["n2"], d1, period - d1, g["cells"])
    ref = xyz_to_lab(ti.bragg_xyz(*mirror, method="spectral", samples_per_fringe=ref_spf, max_samples=1 << 20))
    configs = ({"method": "spectral"}, {"method": "sampled", "samples": 64}, {"method": "envelope", "samples": 64},
               {"method": "piecewise", "subdivisions": 1, "weights": "paper", "correction": "paper"})
    for entry in (e for e in data["entries"] if e["config"] in configs):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # (envelope/piecewise outside their domain)
            de = delta_e_2000(xyz_to_lab(ti.bragg_xyz(*mirror, **entry["config"])), ref).numpy().ravel()
        want = entry["grids"]["fig4"]["per_period"]["244"]
        got = {"median": np.median(de), "p95": np.percentile(de, 95), "max": de.max()}
        for key, value in got.items():
            assert abs(value - want[key]) <= 1e-9 * max(1.0, want[key]), (entry["label"], key, value, want[key])
