#!/usr/bin/env bash
# The test command: set up (venv, the package with the extras the tests use) and run the quick test suite.
#   bash scripts/test.sh              the quick suite, in one process (README states its CPU time)
#   bash scripts/test.sh -m slow      the long checks (tests/tiers.py says why each is long); .ci/run runs both
#   bash scripts/test.sh -m claims    the full form of every number the README and the docs state
# Other arguments go to pytest (a file, -k, -x, -n 4 for four workers ...).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# The suite starts paa-mj processes: with bytecode kept, each loads the package's compiled modules instead of
# compiling its source again (some environments set this variable).
unset PYTHONDONTWRITEBYTECODE
marks=0
for arg in "$@"; do
  case "$arg" in -m*) marks=1 ;; esac
done
if [ "$marks" = 0 ]; then
  # The quick suite in one process: each kernel it uses compiled once, when a test first needs it. (Workers would
  # each compile the first kernels at the same time, then load their own copies of the rest: more CPU time.)
  exec .venv/bin/python -m pytest -q "$@"
fi
# The long checks: one pytest worker per core, 2 to 4, after every numba kernel is compiled (or loaded from the
# cache) once, so that the workers, and each process the tests start, do not compile the same kernels again.
workers=$(.venv/bin/python -c "import os; print(max(2, min(4, len(os.sched_getaffinity(0)))))")
.venv/bin/python -m paa_mj.cli compile
exec .venv/bin/python -m pytest -q -n "$workers" "$@"
