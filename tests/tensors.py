"""Small tensor helpers shared by the tests (float64 reference precision)."""

import numpy as np
import torch

F64 = torch.float64
C128 = torch.complex128
POLS = ("s", "p", "unpolarized")
METALS = ("Ag", "Au", "Cu", "Al", "Si")


def t64(x):
    """x as a float64 tensor."""
    return torch.as_tensor(x, dtype=F64)


def tc128(x):
    """x as a complex128 tensor (numbers, lists or arrays)."""
    return torch.as_tensor(np.asarray(x, dtype=complex), dtype=C128)
