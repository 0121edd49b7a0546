"""Every public function and class has a runnable example in its docstring (issue 26.5: "every
public name … with shapes, units and an example each"). The examples themselves run as doctests
(``--doctest-modules`` over src/torchirid); this test fails when a new public name comes without
one."""

from __future__ import annotations

import importlib
import inspect

import pytest

import torchirid

PACKAGES = ("optics", "microfacet", "layered", "spectral", "color", "ibl", "estimation", "fitting", "realtime",
            "scale", "materials", "lut", "export")


def _public(module):
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isfunction(obj) or inspect.isclass(obj):
            yield name, obj


@pytest.mark.parametrize("package", ["torchirid", *PACKAGES])
def test_every_public_function_and_class_has_an_example(package):
    module = torchirid if package == "torchirid" else importlib.import_module(f"torchirid.{package}")
    missing = [name for name, obj in _public(module) if ">>>" not in (inspect.getdoc(obj) or "")]
    assert not missing, f"torchirid.{package}: no >>> example in the docstring of {missing}"
