"""``torchirid explore``: write (and optionally serve on localhost) the interactive WebGL2 explorer page."""

from __future__ import annotations

from .. import _args

NAME = "explore"


def add_parser(subparsers):
    """Register ``explore`` on an argparse subparsers object (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="write (or serve on localhost) the interactive WebGL2 explorer page of Bragg mirrors and thin films",
        description=(
            "Write a static page into --out (index.html, explorer.js, explorer.css, data.js):\n"
            "a sphere under the prefiltered sky, a scatterogram, the reflectance map R(θ, λ)\n"
            "and the colour strip against angle of a Bragg mirror (sliders Λ, δ, N, α) or a\n"
            "thin film (sliders d, n, base, α), drawn with WebGL2 from the shipped fitted\n"
            "textures of torchirid.realtime and the library's GLSL. Nothing is fetched at run\n"
            "time: open index.html in any browser with WebGL2, or pass --serve to serve the\n"
            "folder on http://127.0.0.1:PORT/ until Ctrl-C."
        ),
    )
    p.add_argument("--out", default="out/explorer", metavar="DIR", help="folder of the page (created)")
    p.add_argument("--serve", action="store_true", help="serve --out on localhost after writing it (Ctrl-C stops)")
    p.add_argument("--port", type=int, default=8000, help="port of --serve (0: any free port)")
    p.add_argument("--host", default="127.0.0.1", help="address of --serve (default: this machine only)")
    _args.add_output_options(p, figures=False)
    p.set_defaults(func=run, parser=p)
    return p


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Write the page; with ``--serve`` serve it until interrupted. Exit status 0; 1 (cannot write or bind); 2 (bad argument)."""
    import signal
    import sys
    import time
    from pathlib import Path

    from ..explorer import page_data, serve, write_page

    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port must lie in [0, 65535] (0: any free port); got {args.port}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out must be a folder; {out} is a file")
    if not args.quiet:
        print(f"{NAME}: preparing the page data (textures, prefiltered sky) ...", file=sys.stderr, flush=True)
    data = page_data()
    try:
        index = write_page(out, data=data)
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    print(f"wrote {index} (open it in a browser with WebGL2)", flush=True)
    if not args.serve:
        return 0
    try:
        server, url = serve(out, host=args.host, port=args.port)
    except OSError as e:
        return _args.fail(NAME, f"cannot serve on {args.host}:{args.port}: {e}", status=1)
    # Ctrl-C (SIGINT) stops the server even when this process was started with SIGINT ignored or
    # blocked (a background job, a test runner's worker): Python then installs no handler of its own
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:  # the announcement inside: a Ctrl-C right after it is still a clean stop
        print(f"serving {out} on {url} (Ctrl-C stops)", flush=True)
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        server.shutdown()
        server.server_close()
    return 0
