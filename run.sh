#!/usr/bin/env bash
# One-stop entry point: sets up .venv on first use (python3 is all it needs), then
#   ./run.sh demo [ARGS]   -> warpvol demo [ARGS]   (built-in scene, default pipeline, image + report)
#   ./run.sh test [ARGS]   -> pytest [ARGS]
#   ./run.sh warpvol ARGS  -> any warpvol command
# demo, warpvol and python run in the caller's folder (relative paths are the caller's); test runs in the
# repository, where pytest finds its configuration and tests.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")" && pwd)"
VENV="$ROOT/.venv"
if [ ! -x "$VENV/bin/python" ] || [ "$ROOT/pyproject.toml" -nt "$VENV/.installed" ]; then
    echo "[run.sh] setting up .venv (first run only) ..." >&2
    python3 -m venv "$VENV"
    "$VENV/bin/python" -m pip install -q --upgrade pip >&2
    # setuptools' editable install ends with an informational note ("Editable installation ... be careful
    # with folders ...") that is no build warning; it is filtered so that real warnings stand out
    (cd "$ROOT" && PYTHONWARNINGS="ignore:Editable installation" "$VENV/bin/python" -m pip install -q -e ".[test]" >&2)
    touch "$VENV/.installed"
fi
cmd="${1:-demo}"
# the bench page's browser test drives Debian's Chromium through playwright; on a fresh machine where
# we may (root, apt-get), install it once; elsewhere the test skips and names why
if [ "$cmd" = test ] && ! command -v chromium >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 \
        && [ ! -e "$VENV/.chromium-tried" ]; then
    echo "[run.sh] installing chromium for the browser test (first run only) ..." >&2
    touch "$VENV/.chromium-tried"
    export DEBIAN_FRONTEND=noninteractive
    { timeout 600 apt-get install -y -q chromium || { timeout 120 apt-get update -q && timeout 600 apt-get install -y -q chromium; }; } \
        >/dev/null 2>&1 || echo "[run.sh] chromium could not be installed; the browser test will skip" >&2
fi
shift || true
case "$cmd" in
    demo) exec "$VENV/bin/warpvol" demo "$@" ;;
    test) cd "$ROOT" && exec "$VENV/bin/python" -m pytest "$@" ;;
    warpvol) exec "$VENV/bin/warpvol" "$@" ;;
    python) exec "$VENV/bin/python" "$@" ;;
    *) echo "usage: ./run.sh demo|test|warpvol|python [ARGS]" >&2; exit 2 ;;
esac
