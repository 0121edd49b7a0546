"""``torchirid film-table`` (torchirid.app.commands.film_table): Hirayama 2000 §5 tables written as LUT files."""

from __future__ import annotations

import argparse

import torch

from torchirid.app.commands.film_table import add_parser
from torchirid.lut import LUT
from torchirid.optics.film_stack import film_reflectance
from torchirid.presets import hirayama_stacks
from torchirid.optics.film_tables import BUILDER


def test_cli_hook(tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="torchirid")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["film-table", "--stack", "sphere", "--angles", "9", "--wavelengths", "400", "700",
                              "13", "--out", str(tmp_path), "--check"])
    assert args.func(args) == 0
    lut = LUT.read(tmp_path / "sphere.npz", builder=BUILDER)
    assert lut.values.shape == (9, 13, 2) and lut.dtype == torch.float32
    ref, _ = film_reflectance(lut.axes["wavelength"].double(), lut.axes["cos_theta"].double()[:, None],
                              hirayama_stacks()["sphere"])
    assert float((lut.values[..., 0].double() - ref).abs().max()) < 1e-6
    assert "max |Δk_r|" in capsys.readouterr().out
    bad = parser.parse_args(["film-table", "--wavelengths", "200", "700", "13", "--out", str(tmp_path),
                             "--stack", "cylinder"])
    assert bad.func(bad) == 2  # silicon (Green 2008) starts at 250 nm: a bad argument, exit status 2
    err = capsys.readouterr().err
    assert err.startswith("torchirid film-table: error:") and err.count("\n") == 1
