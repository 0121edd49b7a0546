"""torchirid.design.problem: a problem is checked when it is built, errors name the entry."""

from __future__ import annotations

import pytest

from torchirid import design
from torchirid.design.problem import SpecError

R550 = design.SpectralTarget("R", [550.0])


def test_checked_forms():
    p = design.Problem([design.Layer(["TiO2", ("main", "ZnS", "Querry"), 2.0], (10, 50)), design.Layer(1.38, 100)],
                       R550, n_substrate="glass")
    assert p.choices == 1 and p.free_thicknesses == 1 and p.layers[1].thickness == 100.0
    assert p.targets[0].cos_theta == (1.0,) and p.targets[0].p == 2.0
    assert design.Problem(p.layers, p.targets, n_substrate=p.n_substrate).layers == p.layers  # checks are idempotent
    assert design.Layer(1.5, (20, 20)).check("x").thickness == 20.0  # an empty interval is a fixed thickness


@pytest.mark.parametrize("kwargs, key", [
    (dict(layers=[]), "layers"),
    (dict(layers=[design.Layer(1.5, (100, 10))]), "layers[0].thickness"),
    (dict(layers=[design.Layer(1.5, 2e-9)]), "layers[0].thickness"),
    (dict(layers=[design.Layer(-1.5, 10)]), "layers[0].material"),
    (dict(layers=[design.Layer([], 10)]), "layers[0].material"),
    (dict(n_incident=1.5 + 0.1j), "n_incident"),
    (dict(n_substrate="unobtainium"), "n_substrate"),
    (dict(targets=[design.SpectralTarget("Q", [550.0])]), "targets[0].quantity"),
    (dict(targets=[design.SpectralTarget("R", [0.55])]), "targets[0].wavelength"),
    (dict(targets=[design.SpectralTarget("R", [550.0], cos_theta=0.0)]), "targets[0].cos_theta"),
    (dict(targets=[design.SpectralTarget("R", [550.0, 600.0], value=[1, 2, 3])]), "targets[0].value"),
    (dict(targets=[design.SpectralTarget("R", [550.0], weight="sunlight")]), "targets[0].weight"),
    (dict(targets=[design.SpectralTarget("R", [550.0], p=0.5)]), "targets[0].p"),
    (dict(targets=[design.ColourTarget([50.0, 0.0], cos_theta=1.0)]), "targets[0].lab"),
    (dict(targets=[design.ColourTarget([50.0, 0.0, 0.0], illuminant="F2")]), "targets[0].illuminant"),
    (dict(targets=[design.SpectralTarget("R", [300.0])], n_substrate="PET"), "n_substrate"),
    (dict(max_layers=0), "max_layers"),
    (dict(robust=design.Robust(sigma=[1.0, 2.0])), "robust.sigma"),
])
def test_errors_name_the_entry(kwargs, key):
    args = dict(layers=[design.Layer(1.5, (0, 100))], targets=[R550])
    args.update(kwargs)
    layers, targets = args.pop("layers"), args.pop("targets")
    with pytest.raises(SpecError) as err:
        design.Problem(layers, targets, **args)
    assert str(err.value).startswith(key + ":"), str(err.value)
    assert isinstance(err.value, ValueError) and err.value.key == key
