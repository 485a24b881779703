#!/usr/bin/env bash
# The main job: set up, then reproduce the paper (simulations, figures, report, video).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
out=${1:-out/reproduction}
.venv/bin/paa-mj reproduce --out "$out"
