#!/usr/bin/env bash
# The test command: set up (venv, the package with the extras the tests use) and run the quick test suite.
#   bash scripts/test.sh              the quick suite (what .ci/run calls)
#   bash scripts/test.sh -m slow      the long checks whose small forms the quick suite runs
#   bash scripts/test.sh -m claims    the full form of every number the README and the docs state
# Other arguments go to pytest (a file, -k, -x ...).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# One pytest worker per core, 2 to 4: the suite's heavy tests are independent, and more workers
# would each compile and hold their own copy of the numba kernels.
workers=$(.venv/bin/python -c "import os; print(max(2, min(4, len(os.sched_getaffinity(0)))))")
# The suite starts dozens of paa-mj processes: with bytecode kept, each loads the package's
# compiled modules instead of compiling its source again (some environments set this variable).
unset PYTHONDONTWRITEBYTECODE
# Every numba kernel compiled (or loaded from its cache) once, before the workers start: on a fresh clone
# each worker, and each process the tests start, would otherwise compile the same kernels again.
.venv/bin/python -m paa_mj.cli compile
exec .venv/bin/python -m pytest -q -n "$workers" "$@"
