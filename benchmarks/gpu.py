"""GPU against CPU, and against tmm_fast on the GPU: ns per point of the spectral kernels.

Kernels as in benchmarks/throughput.py: ``bragg_reflectance`` (Fourneau Fig. 1's mirror, N = 20),
``thin_film_reflectance`` (1.33 / 300 nm on 1.5) and ``multilayer`` (L = 10, R and T), float64
(and float32 on the GPU), unpolarized, no gradient, on W wavelengths × A angles grids of 10⁴ to
10⁸ points. Columns: ours on the CPU (all cores), ours on CUDA with the default (auto) block size
and with blocks of 2¹⁵ (the CPU's) and in one piece, float32 on CUDA, tmm_fast's ``coh_tmm`` on
CUDA (s and p), and the ratios GPU ÷ CPU and tmm_fast ÷ ours on the GPU. GPU times: best of
``--repeats`` after a warm-up, ``torch.cuda.synchronize()`` around each call. Then the colour
of a Bragg mirror (``bragg_xyz``: spectral, piecewise) over 10⁵ angles, CPU and GPU, and the
host synchronisations per call of each colour method (``torch.cuda.set_sync_debug_mode``).

Needs a CUDA device (``torch.cuda.is_available()``); prints a markdown report and writes it to
``--out``. Run: ``python benchmarks/gpu.py --out benchmarks/results/gpu.md`` (~3 min on an H200).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import torch

import torchirid as ti

F = torch.float64


def grid(size, device, dtype=F):
    W = min(2001, max(2, size // 10))
    A = max(1, size // W)
    lam = torch.linspace(380.0, 780.0, W, dtype=dtype, device=device)
    theta = torch.linspace(0.0, 1.5, A, dtype=dtype, device=device)
    return lam, torch.cos(theta)[:, None], theta


def stacks(device, cdtype=torch.complex128):
    """The 10-film multilayer of benchmarks/throughput.py: (indices (12,), thicknesses (10,) nm)."""
    L = 10
    idx = torch.tensor([1.0] + [1.38, 2.3] * (L // 2) + [1.52], dtype=cdtype, device=device)
    thk = torch.tensor([100.0, 60.0] * (L // 2), dtype=F, device=device)
    return idx, thk


def ours(kernel, lam, c):
    cdt = torch.complex64 if lam.dtype == torch.float32 else torch.complex128
    idx, thk = stacks(lam.device, cdt)
    thk = thk.to(lam.dtype)
    return {
        "bragg": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
        "thin_film": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
        "multilayer": lambda: ti.multilayer(lam, c, idx, thk),
    }[kernel]


def peer(kernel, lam, theta):
    import tmm_fast

    dev = lam.device
    idx = {"bragg": torch.tensor([1.0] + [1.0, 1.5] * 20 + [1.0], dtype=torch.complex128),
           "multilayer": stacks("cpu")[0],
           "thin_film": torch.tensor([1.0, 1.33, 1.5], dtype=torch.complex128)}[kernel]
    thk = {"bragg": torch.tensor([125.0, 375.0] * 20, dtype=F), "multilayer": stacks("cpu")[1],
           "thin_film": torch.tensor([300.0], dtype=F)}[kernel]
    M = idx[None, :, None].expand(1, idx.numel(), lam.numel()).contiguous().to(dev)
    T = torch.cat([torch.tensor([float("inf")], dtype=F), thk * 1e-9, torch.tensor([float("inf")], dtype=F)])[None]
    lm = lam * 1e-9
    return lambda: [tmm_fast.coh_tmm(p, M, T.to(dev), theta, lm, device=str(dev))["R"] for p in ("s", "p")]


def best(fn, repeats, cuda):
    def once():
        if cuda:
            torch.cuda.synchronize()
        t = time.perf_counter()
        out = fn()
        if cuda:
            torch.cuda.synchronize()
        return time.perf_counter() - t, out

    once()  # warm-up (caches, kernels, allocator)
    return min(once()[0] for _ in range(repeats))


def ns(fn, points, repeats, cuda, chunk="auto"):
    try:
        with torch.no_grad(), ti.options(chunk_size=chunk):
            return best(fn, repeats, cuda) / points * 1e9
    except torch.OutOfMemoryError:
        if torch.cuda.is_available():
            torch.cuda.empty_cache()
        return float("nan")


def fmt(x, spec=".2f"):
    return "–" if x is None or x != x else format(x, spec)


def syncs(call):
    torch.cuda.synchronize()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        torch.cuda.set_sync_debug_mode("warn")
        try:
            call()
        finally:
            torch.cuda.set_sync_debug_mode("default")
    return sum("synchroniz" in str(w.message) for w in caught)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e4,1e6,1e7,1e8")
    ap.add_argument("--cpu-max", type=float, default=1e7, help="largest grid timed on the CPU")
    ap.add_argument("--peer-max", type=float, default=1e7, help="largest grid timed with tmm_fast")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--kernels", default="bragg,thin_film,multilayer")
    ap.add_argument("--colours", type=int, default=20_000, help="angles of the bragg_xyz timing")
    ap.add_argument("--sweep", default="", help="block sizes (points, 'none') timed at the largest size")
    ap.add_argument("--no-table", action="store_true", help="only the block-size sweep and the colours")
    ap.add_argument("--out", default=None)
    ap.add_argument("--device", default="cuda", help=argparse.SUPPRESS)  # (cpu: a dry run of the script)
    args = ap.parse_args(argv)
    gpu, cpu = torch.device(args.device), torch.device("cpu")
    cuda = gpu.type == "cuda"
    if cuda and not torch.cuda.is_available():
        raise SystemExit("gpu.py: no CUDA device (torch.cuda.is_available() is False)")
    torch.set_num_threads(os.cpu_count() or 1)
    lines = [f"# GPU vs CPU ({torch.cuda.get_device_name() if cuda else gpu}, torch {torch.__version__}, "
             f"{torch.get_num_threads()} CPU threads)", "",
             "ns per point (best of %d after a warm-up); auto = the default block size per device "
             "(CPU 2¹⁵, GPU %d points)." % (args.repeats, ti.get_chunk_size("cuda")), "",
             "| kernel | points | CPU f64 | GPU f64 auto | GPU f64 2¹⁵ blocks | GPU f64 one piece | GPU f32 auto "
             "| tmm_fast GPU f64 | GPU ÷ CPU speed-up | ours ÷ tmm_fast on GPU |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    print("\n".join(lines), flush=True)
    for kernel in ([] if args.no_table else args.kernels.split(",")):
        for size in (int(float(s)) for s in args.sizes.split(",")):
            lam, c, theta = grid(size, gpu)
            points = lam.numel() * c.numel()
            g_auto = ns(ours(kernel, lam, c), points, args.repeats, cuda)
            g_small = ns(ours(kernel, lam, c), points, args.repeats, cuda, 1 << 15) if size <= 10**7 else None
            g_one = ns(ours(kernel, lam, c), points, args.repeats, cuda, None)
            lam32, c32, _ = grid(size, gpu, torch.float32)
            g32 = ns(ours(kernel, lam32, c32), points, args.repeats, cuda)
            del lam32, c32
            c_ns = None
            if size <= args.cpu_max:
                lc, cc, _ = grid(size, cpu)
                c_ns = ns(ours(kernel, lc, cc), points, max(1, args.repeats - 1), False)
            p_ns = None
            if size <= args.peer_max:
                try:
                    p_ns = ns(peer(kernel, lam, theta), lam.numel() * c.numel(), args.repeats, cuda)
                except Exception as exc:  # noqa: BLE001 (a peer failure is a table cell)
                    print(f"tmm_fast {kernel} {size}: {type(exc).__name__}: {str(exc)[:100]}", flush=True)
            del lam, c, theta
            if cuda:
                torch.cuda.empty_cache()
            row = (f"| {kernel} | {points:,} | {fmt(c_ns)} | {fmt(g_auto, '.3f')} | {fmt(g_small, '.3f')} | "
                   f"{fmt(g_one, '.3f')} | {fmt(g32, '.3f')} | {fmt(p_ns, '.3f')} | "
                   f"{fmt(c_ns / g_auto if c_ns else None, '.0f')}× | "
                   f"{fmt(p_ns / g_auto if p_ns else None, '.1f')}× |")
            lines.append(row)
            print(row, flush=True)

    if args.sweep:
        size = max(int(float(s)) for s in args.sizes.split(","))
        blocks = [None if b.strip().lower() == "none" else int(float(b)) for b in args.sweep.split(",")]
        lines += ["", f"Block size on the GPU, {size:,} points, float64: ns per point", "",
                  "| kernel | " + " | ".join("one piece" if b is None else f"{b:,}" for b in blocks) + " |",
                  "|---|" + "---:|" * len(blocks)]
        print("\n".join(lines[-4:]), flush=True)
        for kernel in args.kernels.split(","):
            lam, c, _ = grid(size, gpu)
            cells = [fmt(ns(ours(kernel, lam, c), lam.numel() * c.numel(), args.repeats, cuda, b), ".3f")
                     for b in blocks]
            del lam, c
            lines.append(f"| {kernel} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    lines += ["", f"Colour of a Bragg mirror (`bragg_xyz`, N = 20, {args.colours:,} angles): ns per colour, and host "
              "synchronisations per call on the GPU (a tenth and all of those angles, value checks off).", "",
              "| method | CPU ns/colour | GPU ns/colour | GPU ÷ CPU | syncs (n/10) | syncs (n) |", "|---|---:|---:|---:|---:|---:|"]
    print("\n".join(lines[-4:]), flush=True)
    for method in ("spectral", "piecewise", "envelope"):
        res = {}
        for key, dev in (("cpu", cpu), ("gpu", gpu)):
            cth = torch.linspace(0.05, 1.0, args.colours, dtype=F, device=dev)
            res[key] = ns(lambda: ti.bragg_xyz(cth, 1.0, 1.5, 125.0, 375.0, 20, method=method),
                               cth.numel(), 2, dev.type == "cuda")
        with ti.options(value_checks=False):
            s = ["–", "–"] if not cuda else [syncs(lambda n=n: ti.bragg_xyz(torch.linspace(0.05, 1.0, n, dtype=F, device=gpu), 1.0, 1.5,
                                                125.0, 375.0, 20, method=method)) for n in (args.colours // 10, args.colours)]
        row = (f"| {method} | {fmt(res['cpu'], '.0f')} | {fmt(res['gpu'], '.1f')} | "
               f"{fmt(res['cpu'] / res['gpu'], '.0f')}× | {s[0]} | {s[1]} |")
        lines.append(row)
        print(row, flush=True)
    text = "\n".join(lines) + "\n"
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
