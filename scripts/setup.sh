#!/usr/bin/env bash
# Make the project runnable on a fresh Debian/Ubuntu machine: the Debian packages for
# headless rendering (EGL through Mesa, OSMesa), a virtual environment in .venv and the
# package with its extras. Safe to run again: it only adds what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

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
quiet() {  # the command's own exit status; pip's warnings about local package folders this machine lacks dropped
  "$@" 2>&1 | { grep -v '^WARNING: Location' || true; }
  return "${PIPESTATUS[0]}"
}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  # the newest pip and uv put in by the system's pip (a venv's own pip bootstrap costs more than both), else
  # the venv's own pip, brought up to date
  if ! { "$python" -m pip --version >/dev/null 2>&1 && "$python" -m venv --without-pip .venv \
         && quiet "$python" -m pip --python .venv/bin/python install -q --disable-pip-version-check --upgrade pip uv; }
  then
    rm -rf .venv
    "$python" -m venv .venv
    quiet .venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip || true
  fi
fi
# The package and its extras: by uv where it can be had (the same packages as pip resolves, installed in about
# a third of pip's CPU time), else by pip. Neither compiles every module of every package at install time:
# Python compiles the modules a run imports when it imports them, which costs less than compiling them all.
# Drake (extra "peers", for paa-mj peers and its tests) comes in the same install where a wheel exists
# (Linux x86_64, macOS); elsewhere the install is done again without it, and those tests are skipped.
if [ -x .venv/bin/uv ] || quiet .venv/bin/python -m pip install -q --disable-pip-version-check uv; then
  installer=uv
else
  installer=pip
fi
install() {
  if [ "$installer" = uv ] && .venv/bin/uv pip install --python .venv/bin/python -q -e ".[$1]"; then
    return 0
  fi
  quiet .venv/bin/python -m pip install -q --disable-pip-version-check --no-compile -e ".[$1]"
}
# MuJoCo Warp (extra "gpu") comes too, so that the tests run its engine on Warp's CPU device; where it cannot be
# installed, those tests are skipped.
if ! install "dev,peers,gpu"; then
  echo "setup: MuJoCo Warp could not be installed; the tests of --engine warp will be skipped" >&2
  if ! install "dev,peers"; then
    echo "setup: Drake could not be installed; the tests of paa-mj peers will be skipped" >&2
    install dev || true
  fi
fi
.venv/bin/python -c "import paa_mj, mujoco" || { echo "setup: the install failed" >&2; exit 1; }
