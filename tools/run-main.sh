#!/usr/bin/env bash
# tools/run-main.sh - build the host firmware and run the paper's experiments.
# Skeleton: bootstrap, build the host-double preset, then hand over to tools/experiments.sh
# (if present), passing along any arguments.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"

tools/bootstrap.sh
cmake --preset host-double
cmake --build --preset host-double

if [ -x tools/experiments.sh ] || [ -f tools/experiments.sh ]; then
    exec bash tools/experiments.sh "$@"
fi
echo "[run-main] tools/experiments.sh not written yet: built build/host-double only"
