#!/usr/bin/env bash
# Make the project runnable on a fresh Debian/Ubuntu machine: the Debian packages for
# headless rendering (EGL through Mesa, OSMesa), a virtual environment in .venv and the
# package. Safe to run again: it only adds what is missing.
#
#   bash scripts/setup.sh          the package and what the tests use: the extras "test", "peers" (Drake) and
#                                  "gpu" (MuJoCo Warp, run on Warp's CPU device), the last two where they install
#   bash scripts/setup.sh --main   the package alone: what paa-mj reproduce (scripts/reproduce.sh) uses
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  --main) main=1 ;;
  "") main=0 ;;
  *) echo "setup: unknown option $1 (--main: the package alone)" >&2; exit 2 ;;
esac

debian_packages=(libosmesa6 libegl1 libegl-mesa0 libgl1-mesa-dri libglx-mesa0)
missing=()
if command -v dpkg >/dev/null 2>&1; then
  for pkg in "${debian_packages[@]}"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then sudo=""; elif command -v sudo >/dev/null 2>&1; then sudo="sudo -n"; else sudo="none"; fi
  if [ "$sudo" = none ]; then
    echo "setup: cannot install ${missing[*]} (not root, no sudo); video rendering may be unavailable" >&2
  else
    echo "setup: installing Debian packages: ${missing[*]}"
    $sudo apt-get update -qq || true
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
      || echo "setup: apt-get could not install ${missing[*]}; video rendering may be unavailable" >&2
  fi
fi

python=${PYTHON:-python3}
if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 10))'; then
  echo "setup: Python >= 3.10 is needed, $python is $("$python" --version 2>&1)" >&2
  exit 1
fi
# A line every 10 s while a step says nothing of its own (uv resolves, pip downloads, in silence).
ticker_pid=""
ticking() {
  local start=$SECONDS
  (  # its sleep ended with it: no process left holding the output open
    trap 'kill "$nap" 2>/dev/null; exit 0' TERM
    while :; do sleep 10 & nap=$!; wait "$nap"; echo "setup: $1, $((SECONDS - start)) s in"; done
  ) &
  ticker_pid=$!
}
stop_ticking() { [ -z "$ticker_pid" ] || kill "$ticker_pid" 2>/dev/null || true; ticker_pid=""; }
trap stop_ticking EXIT
quiet() {  # the command's own exit status; pip's warnings about local package folders this machine lacks dropped
  "$@" 2>&1 | { grep -v '^WARNING: Location' || true; }
  return "${PIPESTATUS[0]}"
}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with uv (or pip) in it"
  ticking "creating .venv"
  # uv put in by the system's pip (a venv's own pip bootstrap costs more; the extra "test" adds pip, which the
  # tests of the wheel use), else the venv's own pip, brought up to date
  if ! { "$python" -m pip --version >/dev/null 2>&1 && "$python" -m venv --without-pip .venv \
         && quiet "$python" -m pip --python .venv/bin/python install -q --disable-pip-version-check uv; }
  then
    rm -rf .venv
    "$python" -m venv .venv
    quiet .venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip || true
  fi
  stop_ticking
fi
# The package and its extras: by uv where it can be had (the same packages as pip resolves, installed in about
# a third of pip's CPU time), else by pip. Neither compiles every module of every package at install time:
# Python compiles the modules a run imports when it imports them, which costs less than compiling them all.
# Each says what it resolves, downloads and installs as it goes.
if [ -x .venv/bin/uv ] || quiet .venv/bin/python -m pip install -q --disable-pip-version-check uv; then
  installer=uv
else
  installer=pip
fi
install() {
  local target=.
  [ -z "$1" ] || target=".[$1]"
  echo "setup: installing paa_mj${1:+ with the extras $1} ($installer)"
  ticking "installing paa_mj${1:+ with the extras $1}"
  local code=0
  if [ "$installer" = uv ] && .venv/bin/uv pip install --python .venv/bin/python -e "$target"; then
    stop_ticking
    return 0
  fi
  quiet .venv/bin/python -m pip install --disable-pip-version-check --no-compile --progress-bar off -e "$target" \
    || code=$?
  stop_ticking
  return "$code"
}
if [ "$main" = 1 ]; then
  install ""
else
  # Drake (extra "peers") and MuJoCo Warp (extra "gpu", whose engine the tests run on Warp's CPU device) come in
  # the same install where wheels exist (Linux x86_64); elsewhere the install is done again without them, and
  # their tests are skipped.
  if ! install "test,peers,gpu"; then
    echo "setup: MuJoCo Warp could not be installed; the tests of --engine warp will be skipped" >&2
    if ! install "test,peers"; then
      echo "setup: Drake could not be installed; the tests of paa-mj peers will be skipped" >&2
      install test || true
    fi
  fi
fi
.venv/bin/python -c "import paa_mj, mujoco" || { echo "setup: the install failed" >&2; exit 1; }
echo "setup: done ($(du -sh .venv 2>/dev/null | cut -f1) in .venv)"
