"""Count torchirid's public API surface (issue: one shape per family).

    .venv/bin/python benchmarks/api_surface.py [--list]

Prints the number of names in the root ``__all__``, the number of unique public names over the
root and every public subpackage's / top-level module's ``__all__`` (subpackage names
themselves excluded), and the "second tier": names in a public module's ``__all__`` that its
package's ``__all__`` does not export.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys


def surface():
    import torchirid

    root = list(torchirid.__all__)
    packages = {}
    for info in pkgutil.iter_modules(torchirid.__path__):
        if info.name.startswith("_") or info.name == "app":
            continue
        mod = importlib.import_module(f"torchirid.{info.name}")
        packages[info.name] = mod
    subnames = set(packages)
    unique = {n for n in root if n not in subnames and n != "__version__"}
    for name, mod in packages.items():
        unique |= {f"{n}" for n in getattr(mod, "__all__", [])}
    second = []
    for name, mod in packages.items():
        if not hasattr(mod, "__path__"):
            continue
        exported = set(getattr(mod, "__all__", []))
        for info in pkgutil.walk_packages(mod.__path__, prefix=f"torchirid.{name}."):
            leaf = info.name.rsplit(".", 1)[-1]
            if any(part.startswith("_") for part in info.name.split(".")[1:]):
                continue
            sub = importlib.import_module(info.name)
            for n in getattr(sub, "__all__", []):
                if n not in exported:
                    second.append(f"{info.name}.{n}")
    return root, unique, second


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    root, unique, second = surface()
    print(f"root __all__: {len(root)} names")
    print(f"unique public names (root + subpackages' __all__): {len(unique)}")
    print(f"names in a public module's __all__ missing from its package's: {len(second)}")
    if "--list" in argv:
        print("\n".join(sorted(unique)))
        print("-- second tier --")
        print("\n".join(second))


if __name__ == "__main__":
    main()
