#!/usr/bin/env bash
# The test command: set up (venv, packages) and run the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# One pytest worker per core, 2 to 4: the suite's heavy tests are independent, and more workers
# would each compile and hold their own copy of the numba kernels.
workers=$(.venv/bin/python -c "import os; print(max(2, min(4, len(os.sched_getaffinity(0)))))")
# The suite starts about a hundred paa-mj processes: with bytecode kept, each loads the package's
# compiled modules instead of compiling its source again (some environments set this variable).
unset PYTHONDONTWRITEBYTECODE
# The numba kernels of a rollout compiled (or loaded from their cache) once, before the workers start:
# each worker would otherwise compile the same kernels at the same time on a fresh clone.
.venv/bin/python -m paa_mj.cli simulate --t-final 0.01 --json > /dev/null
exec .venv/bin/python -m pytest -q -n "$workers" "$@"
