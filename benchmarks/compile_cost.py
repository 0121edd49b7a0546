"""First-call cost of the compiled Bragg kernel, cold and cached across processes (issue 23.3).

``torchirid.options(compile=True)`` compiles the Bragg closed form with ``torch.compile(dynamic=True,
fullgraph=True)``: one compile covers every grid size and every chunk. Inductor keeps the
generated code in its on-disk cache (``TORCHINDUCTOR_CACHE_DIR``, default
``/tmp/torchinductor_$USER``), so a second process skips code generation and the C++ build and
pays only the tracing. Each measurement is a fresh process on a 401 × 90 grid (float64,
unpolarized, 2 threads): the first call's time (compile + one evaluation) and the steady
per-call time, with

* ``cold``: an empty cache directory (the first process on a machine);
* ``warm``: the same directory again (every later process);
* ``warm, float32``: another dtype in a warm process (a second variant).

Run: ``.venv/bin/python benchmarks/compile_cost.py`` (~1 min).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CHILD = r'''
import json, sys, time
import torch, torchirid as ti
torch.set_num_threads(2)
ti.options(compile=True)
out = {}
for dtype in sys.argv[1].split(","):
    F = getattr(torch, dtype)
    lam = torch.linspace(380.0, 780.0, 401, dtype=F)
    c = torch.cos(torch.linspace(0.0, 1.5, 90, dtype=F))[:, None]
    f = lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20)
    t = time.perf_counter(); f(); first = time.perf_counter() - t
    ts = []
    for _ in range(5):
        t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
    out[dtype] = {"first_s": first, "steady_ms": min(ts) * 1e3}
print(json.dumps(out))
'''


def run(cache_dir, dtypes):
    env = dict(os.environ, TORCHINDUCTOR_CACHE_DIR=cache_dir)
    proc = subprocess.run([sys.executable, "-c", CHILD, dtypes], capture_output=True, text=True, env=env,
                          timeout=600)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr[-2000:])
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as cache:
        cold = run(cache, "float64")["float64"]
        warm = run(cache, "float64")["float64"]
        both = run(cache, "float64,float32")
    print("| process | first call (s) | steady call (ms) |")
    print("|---|---:|---:|")
    print(f"| cold cache, float64 | {cold['first_s']:.1f} | {cold['steady_ms']:.2f} |")
    print(f"| warm cache, float64 | {warm['first_s']:.1f} | {warm['steady_ms']:.2f} |")
    print(f"| warm cache, then float32 in the same process (cold variant) | {both['float32']['first_s']:.1f} | "
          f"{both['float32']['steady_ms']:.2f} |")


if __name__ == "__main__":
    main()
