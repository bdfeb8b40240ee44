#!/usr/bin/env bash
# The signal and race tests (pytest -m signals) with every core busy: N runs in a row, stopping at
# the first failure, then one more started as a background job (`... &`, which leaves SIGINT
# ignored on entry, as CI runners and scripts start a process).
#
#   tests/stress.sh [N [PYTEST-ARGUMENTS...]]
#
# N = 20 by default; the arguments (default: tests/cli/test_faults.py tests/harness/test_results.py) go to
# pytest after -m "signals and not slow"; PYTHON=... for another interpreter.
set -u
n=${1:-20}
shift $(($# > 0))
cd "$(dirname "$0")/.."
python=${PYTHON:-.venv/bin/python}
tests=("$@")
[ ${#tests[@]} -gt 0 ] || tests=(tests/cli/test_faults.py tests/harness/test_results.py)
pytest=("$python" -m pytest -q -p no:cacheprovider -m "signals and not slow" "${tests[@]}")

busy=()
stop() {
    for pid in "${busy[@]}"; do
        kill "$pid" 2>/dev/null
    done
    wait "${busy[@]}" 2>/dev/null
}
trap stop EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
for _ in $(seq "$(nproc)"); do
    (while :; do :; done) &
    busy+=($!)
done
echo "$(nproc) busy loops: ${busy[*]}"

for k in $(seq "$n"); do
    echo "run $k/$n"
    "${pytest[@]}" || { echo "failed on run $k/$n"; exit 1; }
done
echo "run as a background job (SIGINT ignored)"
"${pytest[@]}" &
wait $! || { echo "failed as a background job"; exit 1; }
echo "all $n runs and the background run passed"
