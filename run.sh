#!/usr/bin/env bash
# One-stop entry point: sets up .venv on first use (python3 is all it needs), then
#   ./run.sh demo [ARGS]   -> warpvol demo [ARGS]   (built-in scene, default pipeline, image + report)
#   ./run.sh test [ARGS]   -> pytest [ARGS]
#   ./run.sh warpvol ARGS  -> any warpvol command
set -euo pipefail
cd "$(dirname "$0")"
if [ ! -x .venv/bin/python ] || [ pyproject.toml -nt .venv/.installed ]; then
    echo "[run.sh] setting up .venv (first run only) ..." >&2
    python3 -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip >&2
    .venv/bin/python -m pip install -q -e ".[test]" >&2
    touch .venv/.installed
fi
cmd="${1:-demo}"
# the bench page's browser test drives Debian's Chromium through playwright; on a fresh machine where
# we may (root, apt-get), install it once; elsewhere the test skips and names why
if [ "$cmd" = test ] && ! command -v chromium >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 \
        && [ ! -e .venv/.chromium-tried ]; then
    echo "[run.sh] installing chromium for the browser test (first run only) ..." >&2
    touch .venv/.chromium-tried
    export DEBIAN_FRONTEND=noninteractive
    { timeout 600 apt-get install -y -q chromium || { timeout 120 apt-get update -q && timeout 600 apt-get install -y -q chromium; }; } \
        >/dev/null 2>&1 || echo "[run.sh] chromium could not be installed; the browser test will skip" >&2
fi
shift || true
case "$cmd" in
    demo) exec .venv/bin/warpvol demo "$@" ;;
    test) exec .venv/bin/python -m pytest "$@" ;;
    warpvol) exec .venv/bin/warpvol "$@" ;;
    python) exec .venv/bin/python "$@" ;;
    *) echo "usage: ./run.sh demo|test|warpvol|python [ARGS]" >&2; exit 2 ;;
esac
