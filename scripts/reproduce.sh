#!/usr/bin/env bash
# The main job: set up the package alone (what the reproduction uses, not the test tools nor the optional engines
# and peers), then reproduce the paper (simulations, figures, report, video).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --main
out=${1:-out/reproduction}
.venv/bin/paa-mj reproduce --out "$out"
