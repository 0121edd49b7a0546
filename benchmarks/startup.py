"""Start-up: ``import torchirid`` plus the first colour, against ``import torch`` alone.

Two commands, each run in a fresh Python process (the same interpreter as this script):

* ``torch``: ``python -c "import torch"``;
* ``torchirid``: ``python -c "import torch, torchirid; <first colour>"``, where the first colour
  is one reflectance spectrum (81 wavelengths, float64) → XYZ → L*a*b* → ΔE2000 against a
  second spectrum, through ``torchirid.color`` (``spectrum_to_xyz``, ``xyz_to_lab``,
  ``delta_e_2000``).

Each round runs both commands once, in alternating order (torch first in even rounds,
torchirid first in odd ones), and times each process from outside: its wall clock from start
to exit (interpreter start-up included in both) and its CPU time (user + system, from
``os.wait4``; steadier than the wall clock on a loaded machine). The figure is the median over
rounds of the per-round ratio torchirid / torch (the bar of issue 34: ≤ 1.25). A last
torchirid run reports which heavy modules (matplotlib, scipy, kornia, colour, pandas, tqdm) are
in ``sys.modules`` after the first colour, and which ``import torch`` alone loads (tqdm).

``--importtime`` also prints the import cost of ``torchirid`` and of each subpackage after
``import torch, torchirid`` (``python -X importtime``, cumulative: a module's own code and
whatever it is the first to import), one fresh process each, and which heavy modules each
import pulls in by itself (torch itself imports tqdm).

Run: ``.venv/bin/python benchmarks/startup.py`` (15 rounds, ~1 min; ``--rounds N``;
``--importtime``; ``--write`` appends the output to benchmarks/results/startup.txt with a label
given by ``--label``; ``--src DIR`` measures the package in another folder, e.g. an older
commit's ``src/`` from ``git archive``).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

HEAVY = ("matplotlib", "scipy", "kornia", "colour", "pandas", "tqdm")

TORCH = "import torch"

FIRST_COLOUR = """\
import torch, torchirid
from torchirid.color import delta_e_2000, spectrum_to_xyz, xyz_to_lab
wavelength = torch.linspace(380.0, 780.0, 81, dtype=torch.float64)
r1 = 0.5 + 0.4 * torch.sin(wavelength / 40.0)
r2 = 0.5 + 0.4 * torch.cos(wavelength / 40.0)
de = delta_e_2000(xyz_to_lab(spectrum_to_xyz(r1, wavelength)), xyz_to_lab(spectrum_to_xyz(r2, wavelength)))
assert de.ndim == 0 and bool(torch.isfinite(de))
"""

REPORT = FIRST_COLOUR + f"""
import sys
print(round(de.item(), 6), ' '.join(m for m in {HEAVY!r} if m in sys.modules) or '-')
"""

SUBPACKAGES = (
    "color",
    "optics",
    "microfacet",
    "materials",
    "lut",
    "layered",
    "spectral",
    "ibl",
    "estimation",
    "fitting",
    "realtime",
    "export",
)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "startup.txt"


def _env(src: Path) -> dict:
    env = dict(os.environ)
    src = str(src)
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def _run(code: str, env: dict, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args, "-c", code], env=env, capture_output=True, text=True, check=True)


def _timed(code: str, env: dict) -> tuple[float, float]:
    """(wall, CPU) seconds of one fresh process: start to exit, and its user + system time."""
    t = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        _run(code, env)  # raises with the error output
    return wall, usage.ru_utime + usage.ru_stime


def _summary(name: str, ratios: list[float]) -> str:
    q = statistics.quantiles(ratios, n=4)
    return (f"{name}: median ratio {statistics.median(ratios):.3f} (quartiles {q[0]:.3f}–{q[2]:.3f}, "
            f"min {min(ratios):.3f}, max {max(ratios):.3f})")


def rounds(n: int, env: dict, out) -> None:
    _run(TORCH, env)  # warm the file cache once for both commands
    _run(FIRST_COLOUR, env)
    a_wall, a_cpu, b_wall, b_cpu = [], [], [], []
    out(f"{'round':>5}  {'torch s':>8}  {'torchirid s':>11}  {'ratio':>6}   {'CPU s: torch':>12}  {'torchirid':>9}  {'ratio':>6}")
    for i in range(n):
        if i % 2 == 0:
            a = _timed(TORCH, env)
            b = _timed(FIRST_COLOUR, env)
        else:
            b = _timed(FIRST_COLOUR, env)
            a = _timed(TORCH, env)
        for lst, v in ((a_wall, a[0]), (a_cpu, a[1]), (b_wall, b[0]), (b_cpu, b[1])):
            lst.append(v)
        out(f"{i:>5}  {a[0]:8.3f}  {b[0]:11.3f}  {b[0] / a[0]:6.3f}   {a[1]:12.3f}  {b[1]:9.3f}  {b[1] / a[1]:6.3f}")
    med = statistics.median
    out(_summary("wall", [y / x for x, y in zip(a_wall, b_wall)])
        + f"; median torch {med(a_wall):.3f} s, torchirid + first colour {med(b_wall):.3f} s")
    out(_summary("CPU ", [y / x for x, y in zip(a_cpu, b_cpu)])
        + f"; median torch {med(a_cpu):.3f} s, torchirid + first colour {med(b_cpu):.3f} s")
    de, _, mods = _run(REPORT, env).stdout.strip().partition(" ")
    out(f"ΔE2000 of the first colour: {de}; heavy modules in sys.modules afterwards: {mods} "
        f"(after import torch alone: {_heavy(TORCH, env)})")


def _cumulative_ms(stderr: str, module: str) -> float | None:
    for line in stderr.splitlines():
        if line.startswith("import time:"):
            parts = [p.strip() for p in line[len("import time:") :].split("|")]
            if len(parts) == 3 and parts[1].isdigit() and parts[2] == module:
                return int(parts[1]) / 1e3
    return None


def _heavy(code: str, env: dict) -> str:
    return _run(code + f"; import sys; print(' '.join(m for m in {HEAVY!r} if m in sys.modules) or '-')", env).stdout.strip()


def importtime(env: dict, out) -> None:
    err = _run("import torch", env, "-X", "importtime").stderr
    out(f"import torch alone: {_cumulative_ms(err, 'torch'):.0f} ms (-X importtime); heavy modules: {_heavy('import torch', env)}")
    err = _run("import torch; import torchirid", env, "-X", "importtime").stderr
    out(f"import torchirid after torch: {_cumulative_ms(err, 'torchirid'):.1f} ms; heavy modules: {_heavy('import torchirid', env)}")
    out("each subpackage alone, fresh process, after `import torch, torchirid` (-X importtime cumulative:")
    out("its own modules and everything it is the first to import), and the heavy modules it pulls in:")
    for s in SUBPACKAGES:
        mod = f"torchirid.{s}"
        try:
            err = _run(f"import torch, torchirid; import {mod}", env, "-X", "importtime").stderr
            ms = _cumulative_ms(err, mod)
            out(f"  {mod:<22} {ms:8.1f} ms  {_heavy('import ' + mod, env)}")
        except subprocess.CalledProcessError as e:
            out(f"  {mod:<22} import failed: {e.stderr.strip().splitlines()[-1]}")


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=15)
    p.add_argument("--importtime", action="store_true", help="per-subpackage import cost and heavy modules")
    p.add_argument("--write", action="store_true", help=f"append the output to {RESULTS.relative_to(ROOT)}")
    p.add_argument("--label", default="", help="a label for the appended block (e.g. before / after)")
    p.add_argument("--src", type=Path, default=ROOT / "src",
                   help="the folder holding the torchirid package to measure (default: this checkout's src/)")
    args = p.parse_args(argv)
    lines = []

    def out(s: str) -> None:
        print(s, flush=True)
        lines.append(s)

    env = _env(args.src)
    import torch  # noqa: PLC0415  (only for the header)

    out(
        f"## {args.label or 'run'}: {datetime.datetime.now().isoformat(timespec='minutes')}, "
        f"Python {platform.python_version()}, torch {torch.__version__}, {os.cpu_count()} CPUs, "
        f"{args.rounds} paired rounds, load average {os.getloadavg()[0]:.1f}"
        + ("" if args.src == ROOT / "src" else f", package from {args.src}")
    )
    rounds(args.rounds, env, out)
    if args.importtime:
        importtime(env, out)
    if args.write:
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        with RESULTS.open("a", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n\n")


if __name__ == "__main__":
    main()
