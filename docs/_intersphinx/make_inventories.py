"""Write the small intersphinx inventories the offline docs build links with.

The build fetches nothing (``bash run.sh docs`` works offline), so the names that torchirid's
docstrings cite from Python, PyTorch and NumPy are listed here with their pages on the projects'
sites and written as Sphinx inventories (``objects.inv`` format 2) next to this script:

    .venv/bin/python docs/_intersphinx/make_inventories.py
"""

from __future__ import annotations

import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: project → (its documentation's root URL, {name: (role, page#anchor relative to the root)})
INVENTORIES = {
    "python": ("https://docs.python.org/3/", {
        "os.replace": ("py:function", "library/os.html#os.replace"),
        "os.PathLike": ("py:class", "library/os.html#os.PathLike"),
        "pathlib.Path": ("py:class", "library/pathlib.html#pathlib.Path"),
        "collections.abc.Callable": ("py:class", "library/collections.abc.html#collections.abc.Callable"),
    }),
    "torch": ("https://docs.pytorch.org/docs/stable/", {
        "torch.Tensor": ("py:class", "tensors.html#torch.Tensor"),
        "torch.Generator": ("py:class", "generated/torch.Generator.html#torch.Generator"),
        "torch.dtype": ("py:class", "tensor_attributes.html#torch.dtype"),
        "torch.device": ("py:class", "tensor_attributes.html#torch.device"),
        "torch.lerp": ("py:function", "generated/torch.lerp.html#torch.lerp"),
        "torch.searchsorted": ("py:function", "generated/torch.searchsorted.html#torch.searchsorted"),
        "torch.compile": ("py:function", "generated/torch.compile.html#torch.compile"),
        "torch.nn.Module": ("py:class", "generated/torch.nn.Module.html#torch.nn.Module"),
        "torch.nn.modules.module.Module": ("py:class", "generated/torch.nn.Module.html#torch.nn.Module"),
    }),
    "numpy": ("https://numpy.org/doc/stable/", {
        "numpy.ndarray": ("py:class", "reference/generated/numpy.ndarray.html#numpy.ndarray"),
    }),
}


def write(project: str, names: dict) -> Path:
    lines = [f"{name} {role} 1 {uri} -" for name, (role, uri) in sorted(names.items())]
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: stable\n"
              "# The remainder of this file is compressed using zlib.\n").encode()
    path = HERE / f"{project}.inv"
    path.write_bytes(header + zlib.compress(("\n".join(lines) + "\n").encode()))
    return path


if __name__ == "__main__":
    for project, (_, names) in INVENTORIES.items():
        print(write(project, names))
