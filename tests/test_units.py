"""Wavelengths are in nm: a value in metres (5e-7) or micrometres (0.5) is refused with a
ValueError that says so, by every kind of function that takes wavelengths, and by the CLI."""

import pytest
import torch

import torchirid
from torchirid.app.cli import main

F64 = torch.float64
METRES = torch.tensor([5e-7, 6e-7], dtype=F64)
MICROMETRES = torch.tensor([0.5, 0.6], dtype=F64)
C = torch.tensor(0.8, dtype=F64)

CALLS = {
    "thin_film_reflectance": lambda lam: torchirid.thin_film_reflectance(lam, C, 1.33, 300.0, 1.5),
    "bragg_reflectance": lambda lam: torchirid.bragg_reflectance(lam, C, 1.0, 1.5, 125.0, 375.0, 20),
    "multilayer": lambda lam: torchirid.multilayer(lam, C, torch.tensor([1.0, 1.5, 2.0]), torch.tensor([100.0])),
    "rough_multilayer_reflectance": lambda lam: torchirid.optics.rough_multilayer_reflectance(
        lam, C, torch.tensor([1.0, 1.5, 2.0]), torch.tensor([100.0]), 5.0, 300.0),
    "spectrum_to_xyz": lambda lam: torchirid.spectrum_to_xyz(torch.ones(2, dtype=F64), lam),
    "refractive_index": lambda lam: torchirid.refractive_index("Ag", lam),
    "bragg_xyz range": lambda lam: torchirid.bragg_xyz(C, 1.0, 1.5, 125.0, 375.0, 20,
                                                       wavelength_range=tuple(lam.tolist())),
    "bragg_xyz piecewise range": lambda lam: torchirid.bragg_xyz(C, 1.0, 1.5, 125.0, 375.0, 20, method="piecewise",
                                                                 wavelength_range=tuple(lam.tolist())),
}


@pytest.mark.parametrize("unit", [METRES, MICROMETRES], ids=["metres", "micrometres"])
@pytest.mark.parametrize("name", list(CALLS))
def test_wavelengths_not_in_nm_are_refused(name, unit):
    with pytest.raises(ValueError, match="in nm"):
        CALLS[name](unit)


@pytest.mark.parametrize("name", list(CALLS))
def test_nm_still_work(name):
    out = CALLS[name](torch.tensor([500.0, 600.0], dtype=F64))
    out = out[0] if isinstance(out, tuple) else out
    assert torch.isfinite(out).all()


def test_far_beyond_the_upper_limit_is_refused_and_nan_propagates():
    with pytest.raises(ValueError, match="in nm"):
        torchirid.thin_film_reflectance(torch.tensor(2e6, dtype=F64), C, 1.33, 300.0, 1.5)
    R = torchirid.thin_film_reflectance(torch.tensor([float("nan"), 500.0], dtype=F64), C, 1.33, 300.0, 1.5)
    assert R[0].isnan() and R[1].isfinite()


def test_cli_spectrum_in_metres_exits_2_with_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["spectrum", "--wavelengths", "5e-7", "7.8e-7", "401", "--out", str(tmp_path)])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "in nm" in err[0] and err[0].startswith("torchirid")
    assert not any(tmp_path.iterdir())
