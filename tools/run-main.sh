#!/usr/bin/env bash
# The main job: the HIL demo on the paper's scenario. The firmware application (caekf-host, the same
# code as the MCU image) estimates on vcan0 while the Python bench drives it over CAN with the truth;
# the four experiments of docs/scenario.md run back to back, the results are compared with caekf-replay,
# Figs 3-6 are drawn and the summary table printed. Output: out/hil/ (or the directory given).
# vcan0: native where the kernel has vcan, otherwise in a throw-away user-mode Linux
# guest (tools/with-vcan.sh).
#   tools/run-main.sh [OUT_DIR]
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"

tools/bootstrap.sh --hil
# The distribution's cmake older than 3.25: bootstrap linked a newer one here.
if [ -d "$REPO/.cache/cmake/bin" ]; then export PATH="$REPO/.cache/cmake/bin:$PATH"; fi
exec tools/hil-main.sh "$@"
