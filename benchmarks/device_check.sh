#!/usr/bin/env bash
# The GPU checks in one run (issue 24.4), for a machine with a CUDA device and a python3 that has
# torch: the device-sensitive tests on CPU and CUDA, the GPU benchmark (benchmarks/gpu.py), then
# the rest of the suite with CUDA visible, time permitting. Packages that machine lacks travel as
# wheels in .whl/ (installed into /tmp/site); the project runs from src/ (PYTHONPATH).
#
#   OUT=results/ bash benchmarks/device_check.sh     (~8 min on an H200; logs and gpu.md in $OUT)
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
OUT="${OUT:-out/device}"
mkdir -p "$OUT"
export PYTHONPATH="$PWD/src" PYTHONUNBUFFERED=1 MPLBACKEND=Agg
if compgen -G ".whl/*.whl" >/dev/null; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
        || exit 1
    export PYTHONPATH="$PYTHONPATH:/tmp/site"
fi
start=$SECONDS
{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
  python3 -c "import torch, os; print('torch', torch.__version__, '| cuda', torch.cuda.is_available(), '|', os.cpu_count(), 'CPUs')"
} 2>&1 | tee "$OUT/gpu_info.txt"

echo "== 1. device-sensitive tests (CPU and CUDA)"
timeout -s INT "${TESTS_S:-180}" python3 -m pytest -q -p no:cacheprovider -o addopts="" -rs \
    tests/test_devices.py tests/test_chunks.py tests/estimation/test_conventions.py 2>&1 \
    | tee "$OUT/device_tests.log" | tail -25
echo "== 2. GPU benchmark ($((SECONDS - start)) s so far)"
timeout "${BENCH_S:-220}" python3 benchmarks/gpu.py --out "$OUT/gpu.md" 2>&1 | tee "$OUT/gpu.log" | tail -40
left=$(( ${TOTAL_S:-560} - (SECONDS - start) ))
echo "== 3. the rest of the suite with CUDA visible (${left} s left)"
if (( left > 60 )); then
    # SIGINT at the limit: pytest stops and still lists the failures so far (-rf, one line each)
    CI=true OMP_NUM_THREADS=2 timeout -s INT "$left" python3 -m pytest -q -p no:cacheprovider -o addopts="" -rf \
        --tb=line -n "${WORKERS:-12}" tests --ignore=tests/scale --ignore=tests/test_devices.py 2>&1 \
        | grep -v -E "^[.FsxE]+ *(\[ *[0-9]+%\])?$" | tee "$OUT/suite.log" | tail -40
fi
echo "== done in $((SECONDS - start)) s"
