#!/usr/bin/env bash
# torchirid: set up the virtualenv and run the main job or the tests.
#
#   bash run.sh                 set up .venv, then write out/spectrum.png and out/spectrum.npz
#   bash run.sh test [ARGS...]  set up .venv, then run the tests (no ARGS: the whole suite, one
#                               worker per core; ARGS go to pytest as given)
#   bash run.sh docs            set up .venv, then build the documentation site into docs/_build/html
#
# Works unattended (CI=true, no stdin). Everything it needs is installed here: torch first,
# pinned (pip takes the local CPU wheel for exactly this version; an unpinned torch would
# pull a multi-GB CUDA build), then the project in editable mode with its dev extra.
set -euo pipefail

TORCH_PIN="torch==2.13.0"

cd "$(dirname "${BASH_SOURCE[0]}")"
ROOT="$(pwd)"
VENV="$ROOT/.venv"
PY="$VENV/bin/python"
STAMP="$VENV/.torchirid-installed"

export PIP_DISABLE_PIP_VERSION_CHECK=1
export PIP_NO_INPUT=1
export MPLBACKEND=Agg

usage() {
    sed -n '2,7p' "$ROOT/run.sh" | sed 's/^# \{0,1\}//'
}

# pip -q still prints warnings; drop only the noise about index locations that this
# machine's pip configuration names but that do not exist. Errors always show.
pip_install() {
    local log rc=0
    log="$(mktemp)"
    "$PY" -m pip install -q "$@" 2>"$log" || rc=$?
    grep -v "^WARNING: Location '.*' is ignored: it is neither a file nor a directory\.$" "$log" >&2 || true
    rm -f "$log"
    if [[ $rc -ne 0 ]]; then
        echo "run.sh: pip install $* failed (exit $rc)" >&2
        exit "$rc"
    fi
}

ensure_venv() {
    # A venv whose interpreter no longer runs (deleted Python) or that lacks pip (an
    # interrupted `python3 -m venv`) is rebuilt.
    if [[ -e "$VENV" ]] && ! "$PY" -c 'import pip' >/dev/null 2>&1; then
        echo "run.sh: $VENV is broken; recreating it" >&2
        rm -rf "$VENV"
    fi
    if [[ ! -x "$PY" ]]; then
        echo "run.sh: creating virtualenv $VENV" >&2
        python3 -m venv "$VENV"
    fi
    if ! "$PY" -c 'import sys; sys.exit(sys.version_info < (3, 10))'; then
        echo "run.sh: torchirid needs Python >= 3.10; $("$PY" --version 2>&1) found" >&2
        exit 1
    fi

    # The stamp records what was installed: pyproject.toml, the torch pin and the repo path
    # (an editable install points at the source tree). Any change triggers a reinstall.
    local want
    want="$("$PY" - "$TORCH_PIN" "$ROOT" <<'EOF'
import hashlib, pathlib, sys
h = hashlib.sha256()
h.update(pathlib.Path("pyproject.toml").read_bytes())
h.update(("\0" + sys.argv[1] + "\0" + sys.argv[2]).encode())
print(h.hexdigest())
EOF
)"
    if [[ -f "$STAMP" && "$(cat "$STAMP")" == "$want" ]]; then
        return 0
    fi
    echo "run.sh: installing $TORCH_PIN and torchirid[dev] into $VENV (quiet; may take a few minutes)" >&2
    rm -f "$STAMP"
    pip_install "$TORCH_PIN"
    pip_install -e ".[dev]"
    printf '%s\n' "$want" >"$STAMP"
}

# Tools some tests use, installed where this machine lets us: Khronos' GLSL reference compiler
# (Debian's glslang-tools) and a browser (Debian's chromium, driven by the Python playwright
# package of the dev extra) for the shader tests, as root with apt-get; Khronos' glTF validator
# (npm's gltf-validator, pinned, into .venv/node_modules) for the glTF export test. Without them
# those tests skip with their reason.
GLTF_VALIDATOR_PIN="gltf-validator@2.0.0-dev.3.10"
# MathJax 3 (npm, pinned, into .venv/node_modules): docs/conf.py stages it into the site so its
# equations render offline; without npm the pages load MathJax from its CDN when viewed.
MATHJAX_PIN="mathjax@3.2.2"

# npm_install PIN FILE WHY FALLBACK: install the pinned npm package into .venv/node_modules
# unless FILE (relative to it) is there; without npm, or when it fails, FALLBACK says what happens
npm_install() {
    if command -v npm >/dev/null 2>&1 && [[ ! -f "$VENV/node_modules/$2" ]]; then
        echo "run.sh: installing $1 (npm; $3)" >&2
        npm install --prefix "$VENV" --no-audit --no-fund --silent "$1" >/dev/null 2>&1 \
            || echo "run.sh: could not install $1; $4" >&2
    fi
}

ensure_mathjax() {
    npm_install "$MATHJAX_PIN" mathjax/es5/tex-chtml.js "the site's equations offline" \
        "the site will load MathJax from its CDN"
}

# Mitsuba's LLVM variants (torchirid.mitsuba's vectorised tests and the gallery's renders): Dr.Jit
# needs libLLVM >= 16 and Debian 12's default libLLVM 15 crashes it (`Cannot select: fminimum`):
# Debian's libllvm19, as root with apt-get, and DRJIT_LIBLLVM_PATH pointed at it. Without it the
# LLVM tests skip with their reason and the gallery renders in the scalar variants.
ensure_llvm() {
    local lib
    lib="$(ls /usr/lib/*/libLLVM-19.so* /usr/lib/*/libLLVM.so.19* 2>/dev/null | head -n 1 || true)"
    if [[ -z "$lib" && "$(id -u)" == 0 ]] && command -v apt-get >/dev/null 2>&1; then
        echo "run.sh: installing libllvm19 (apt-get; Mitsuba's LLVM variants)" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y -q libllvm19 >/dev/null 2>&1 \
            || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q libllvm19 >/dev/null 2>&1; } \
            || echo "run.sh: could not install libllvm19; Mitsuba's LLVM tests will skip" >&2
        lib="$(ls /usr/lib/*/libLLVM-19.so* /usr/lib/*/libLLVM.so.19* 2>/dev/null | head -n 1 || true)"
    fi
    if [[ -n "$lib" && -z "${DRJIT_LIBLLVM_PATH:-}" ]]; then
        export DRJIT_LIBLLVM_PATH="$lib"
    fi
}

ensure_test_tools() {
    ensure_mathjax
    ensure_llvm
    npm_install "$GLTF_VALIDATOR_PIN" gltf-validator/package.json "the glTF validator test" \
        "the glTF validator test will skip"
    local missing=()
    command -v glslangValidator >/dev/null 2>&1 || missing+=(glslang-tools)
    command -v chromium >/dev/null 2>&1 || missing+=(chromium)
    if (( ${#missing[@]} )) && [[ "$(id -u)" == 0 ]] && command -v apt-get >/dev/null 2>&1; then
        echo "run.sh: installing ${missing[*]} (apt-get; the GLSL compile and browser tests)" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y -q "${missing[@]}" >/dev/null 2>&1 \
            || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q "${missing[@]}" >/dev/null 2>&1; } \
            || echo "run.sh: could not install ${missing[*]}; the tests that need them will skip" >&2
    fi
}

cmd="${1:-}"
case "$cmd" in
    "")
        ensure_venv
        "$VENV/bin/torchirid" spectrum --out out/
        echo "run.sh: done; files are in $ROOT/out/ (spectrum.png, spectrum.npz)"
        ;;
    test)
        shift
        ensure_venv
        ensure_test_tools
        if (( $# == 0 )) && "$PY" -c "import xdist" 2>/dev/null; then
            # the whole suite (CI's command): one pytest worker per core, up to 4, a file's tests
            # on one worker (module fixtures: the site build, the gallery run, Dask clusters),
            # one torch thread each (2 workers × 2 threads on 2 cores: many-small-op code slows
            # 10-100×). 2 cores: 278 s instead of 472 s serial. Any argument: pytest as given.
            workers=$(nproc 2>/dev/null || echo 2)
            (( workers > 4 )) && workers=4
            OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}" "$PY" -m pytest -q -n "$workers" --dist loadfile
        else
            "$PY" -m pytest -q "$@"
        fi
        ;;
    docs)
        ensure_venv
        ensure_mathjax
        ensure_llvm
        # offline (the intersphinx inventories are local); -n: every cross-reference must resolve;
        # -W: a warning fails the build
        "$PY" -m sphinx -q -n -W --keep-going -b html docs docs/_build/html
        echo "run.sh: docs built: $ROOT/docs/_build/html/index.html"
        ;;
    -h | --help | help)
        usage
        ;;
    *)
        echo "run.sh: unknown command '$cmd'" >&2
        usage >&2
        exit 2
        ;;
esac
