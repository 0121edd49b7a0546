"""Count torchirid's public API surface (issue: one shape per family).

    .venv/bin/python benchmarks/api_surface.py [--list]

Prints the number of names in the root ``__all__``, the number of unique public names over the
root and every public subpackage's / top-level module's ``__all__`` (subpackage names
themselves excluded), the "second tier": names in a public module's ``__all__`` that its
package's ``__all__`` does not export, and the argument checks: how many public functions declare
their arguments (``@_checks.arguments``) and how many still open with a prologue of 8 or more
lines of ``_checks`` calls (statements of the body that call ``_checks``, outside the return).
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


def checks():
    """(functions declaring their arguments, public functions, [(lines, module, name)] of those
    whose body has >= 8 lines of statements calling _checks), over src/torchirid (not the app)."""
    import ast
    import pathlib

    import torchirid

    root = pathlib.Path(torchirid.__file__).parent
    declared, public, long = 0, 0, []
    for f in sorted(root.rglob("*.py")):
        if "app" in f.relative_to(root).parts:
            continue
        text = f.read_text(encoding="utf-8")
        tree = ast.parse(text)
        names = set()
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                try:
                    names = set(ast.literal_eval(node.value))
                except ValueError:
                    pass
        for node in tree.body:
            if not isinstance(node, ast.FunctionDef) or node.name not in names:
                continue
            public += 1
            if any("arguments" in ast.unparse(d) for d in node.decorator_list):
                declared += 1
            body = node.body[1:] if node.body and isinstance(node.body[0], ast.Expr) else node.body
            lines = sum(ast.get_source_segment(text, st).count("\n") + 1 for st in body
                        if not isinstance(st, (ast.Return, ast.For, ast.With))
                        and "_checks." in ast.get_source_segment(text, st))
            if lines >= 8:
                long.append((lines, str(f.relative_to(root)), node.name))
    return declared, public, sorted(long, reverse=True)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    root, unique, second = surface()
    print(f"root __all__: {len(root)} names")
    print(f"unique public names (root + subpackages' __all__): {len(unique)}")
    print(f"names in a public module's __all__ missing from its package's: {len(second)}")
    declared, public, long = checks()
    print(f"public functions declaring their arguments (@_checks.arguments): {declared} of {public}")
    print(f"public functions with a check prologue of >= 8 lines: {len(long)} "
          + ", ".join(f"{m}:{n} ({k})" for k, m, n in long))
    if "--list" in argv:
        print("\n".join(sorted(unique)))
        print("-- second tier --")
        print("\n".join(second))


if __name__ == "__main__":
    main()
