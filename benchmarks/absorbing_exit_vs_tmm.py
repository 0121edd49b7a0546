"""Transmittance into absorbing substrates against tmm: torchirid's ``multilayer`` T vs
``tmm.coh_tmm``'s T (the Poynting flux just inside the exit medium) on random stacks over
silicon and metal substrates. Prints the largest T (what a T = 0 convention would miss) and
the largest |T − tmm T|.

    .venv/bin/python benchmarks/absorbing_exit_vs_tmm.py [--stacks 40]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from oracles import material_nk, tmm_coh  # noqa: E402

import torchirid  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stacks", type=int, default=40, help="random stacks per substrate")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    g = np.random.default_rng(args.seed)
    largest, errors = 0.0, []
    for sub in ("Si", "Ag", "Au", "Cu", "Al"):
        for _ in range(args.stacks):
            w, c, pol = g.uniform(380, 780), g.uniform(0, 1), str(g.choice(["s", "p"]))
            L = int(g.integers(0, 4))
            films, d = list(g.uniform(1.3, 2.4, L)), list(g.uniform(0, 300, L))
            idx = [1.0, *films, complex(material_nk(sub, w))]
            _, T = torchirid.multilayer(torch.tensor(w, dtype=torch.float64), torch.tensor(c, dtype=torch.float64),
                                        torch.tensor(idx, dtype=torch.complex128),
                                        torch.tensor(d, dtype=torch.float64), polarization=pol)
            ref = tmm_coh(w, c, idx, d, pol)["T"]
            largest = max(largest, ref)
            errors.append(abs(T.item() - ref))
    print(f"{len(errors)} stacks: largest tmm T {largest:.4f}; max |T - tmm T| = {max(errors):.2e}")


if __name__ == "__main__":
    main()
