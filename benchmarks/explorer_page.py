"""The explorer page (``torchirid explore``) against the library: colour error over the sliders'
whole range, redraw times, and the screenshot of docs/figures/explorer.png (issue 25.3).

Drives the page in headless Chromium (Playwright; software WebGL2 through SwiftShader, as in the
tests) and, for a grid of materials covering every slider's range — Bragg mirrors Λ 120–260 nm
× δ {0.3, 0.5, 0.7} × N {6, 8, 10}; thin films d 50–600 nm × n {1.25 … 2.4} × 3 bases — reads the
colour strip (360 angles, θ = (i + ½)/360 · 90°) and compares it with the library's spectral
colour (``torchirid.app.explorer.reference_rgb``, clipped to the sRGB gamut as the page's 8-bit
output is): ΔE2000 per material (mean and max over the angles), and over the grid the median and
the worst of those, and the share of materials within the issue's bar (mean ≤ 1.0, max ≤ 2.5).
Then the redraw time of each view (median of ``--frames``; software rendering on this machine's
CPU cores — a GPU draws the same shaders in well under a millisecond) and the screenshots.

Run: ``.venv/bin/python benchmarks/explorer_page.py --write --screenshot docs/figures/explorer.png``
(~4 min on 2 cores; needs chromium and playwright, which ``bash run.sh test`` installs).
"""

from __future__ import annotations

import argparse
import base64
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from torchirid.app.explorer import BASES, reference_rgb, write_page
from torchirid.color import delta_e_2000, linear_srgb_to_xyz, xyz_to_lab

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "explorer_page.md"
BROWSER_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]


def _strip(page):
    r = page.evaluate("window.torchiridExplorer.read('strip')")
    px = np.frombuffer(base64.b64decode(r["rgba"]), np.uint8).reshape(r["height"], r["width"], 4)
    v = px[r["height"] // 2, :, :3] / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def _delta_e(page, state):
    page.evaluate("(s) => Object.assign(window.torchiridExplorer.state, s)", state)
    got = torch.as_tensor(_strip(page), dtype=torch.float64)
    theta = (np.arange(got.shape[0]) + 0.5) / got.shape[0] * 90.0
    want = reference_rgb(state, theta).clamp(0.0, 1.0)
    lab = lambda rgb: xyz_to_lab(linear_srgb_to_xyz(rgb))  # noqa: E731
    return delta_e_2000(lab(got), lab(want)).numpy()


def materials():
    for cells in (6, 8, 10):
        for delta in (0.3, 0.5, 0.7):
            for period in range(120, 261, 10):
                yield {"family": "bragg", "period": float(period), "delta": delta, "cells": cells}
    for base in range(len(BASES)):
        for n in (1.25, 1.5, 1.8, 2.1, 2.4):
            for d in range(50, 601, 50):
                yield {"family": "film", "thickness": float(d), "n_film": n, "base": base}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20, help="redraws timed per view")
    ap.add_argument("--write", action="store_true", help=f"write {RESULTS.relative_to(ROOT)}")
    ap.add_argument("--screenshot", default=None, metavar="PNG", help="the page's screenshot (and PNG_film.png)")
    args = ap.parse_args(argv)
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("explorer_page.py: needs chromium (Debian: apt-get install chromium)")
    site = Path(tempfile.mkdtemp(prefix="torchirid-explorer-"))
    write_page(site)
    lines = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, headless=True, args=BROWSER_ARGS)
        page = browser.new_page(viewport={"width": 1180, "height": 760})
        errors = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.goto((site / "index.html").as_uri())
        page.wait_for_function("window.torchiridExplorer !== undefined", timeout=60_000)
        start = page.evaluate("({...window.torchiridExplorer.state})")
        rows = {"bragg": [], "film": []}
        worst = {"bragg": (0.0, None), "film": (0.0, None)}
        for state in materials():
            de = _delta_e(page, state)
            rows[state["family"]].append((float(de.mean()), float(de.max())))
            if de.max() > worst[state["family"]][0]:
                worst[state["family"]] = (float(de.max()), state)
        lines += ["| family | materials | median of mean ΔE | worst mean ΔE | median of max ΔE | worst max ΔE "
                  "| within bar (mean ≤ 1.0, max ≤ 2.5) | worst material |", "|---|---:|---:|---:|---:|---:|---:|---|"]
        for family, r in rows.items():
            a = np.asarray(r)
            ok = np.mean((a[:, 0] <= 1.0) & (a[:, 1] <= 2.5))
            state = {k: v for k, v in worst[family][1].items() if k != "family"}
            lines.append(f"| {family} | {len(a)} | {np.median(a[:, 0]):.2f} | {a[:, 0].max():.2f} | "
                         f"{np.median(a[:, 1]):.2f} | {a[:, 1].max():.2f} | {100 * ok:.0f} % | {state} |")
        page.evaluate("(s) => Object.assign(window.torchiridExplorer.state, s)", start)
        lines += ["", "| view | pixels | median redraw (ms) |", "|---|---:|---:|"]
        for view in ("sphere", "scatterogram", "rmap", "strip"):
            ms = page.evaluate("""([view, frames]) => {
                const e = window.torchiridExplorer, t = [];
                for (let i = 0; i < frames; i++) { const t0 = performance.now(); e.read(view); t.push(performance.now() - t0); }
                t.sort((a, b) => a - b); return t[t.length >> 1]; }""", [view, args.frames])
            size = page.evaluate(f"[document.getElementById({view!r}).width, document.getElementById({view!r}).height]")
            lines.append(f"| {view} | {size[0]} × {size[1]} | {ms:.1f} |")
        if args.screenshot:
            shot = Path(args.screenshot)
            shot.parent.mkdir(parents=True, exist_ok=True)
            page.evaluate("window.torchiridExplorer.render()")
            page.screenshot(path=str(shot))
            page.check("input[name=family][value=film]")
            page.evaluate("window.torchiridExplorer.render()")
            page.screenshot(path=str(shot.with_name(shot.stem + "_film.png")))
        browser.close()
    if errors:
        raise SystemExit(f"console errors: {errors}")
    report = "\n".join(lines)
    print(report)
    if args.write:
        RESULTS.write_text("# The explorer page against the library\n\nCommand: `.venv/bin/python "
                           "benchmarks/explorer_page.py --write --screenshot docs/figures/explorer.png` "
                           f"({time.strftime('%Y-%m-%d')}, headless Chromium with SwiftShader on this machine's 2 "
                           "cores). ΔE2000 between the page's colour strip (360 angles from 0° to 90°, 8-bit sRGB) "
                           "and the library's spectral colour, per material; redraw times are software rendering "
                           "(each includes a pixel read-back that waits for the draw).\n\n" + report + "\n")


if __name__ == "__main__":
    torch.set_num_threads(2)
    main()
