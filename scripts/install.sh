#!/usr/bin/env bash
# Installs what is missing, quickly when nothing is: Debian packages (Ipopt, ASL, MUMPS, BLAS/LAPACK,
# cmake, pkg-config, compiler, headless Chromium for the report test, strace for the test of a signal
# during a rename), the virtual environment .venv
# with ecostudy editable, and PyNumero's ASL library built against Debian's libamplsolver into .pyomo/
# (PYOMO_CONFIG_DIR). See DEVELOPERS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
DEB_PKGS="coinor-libipopt-dev libamplsolver-dev liblapack-dev libblas-dev libmumps-seq-dev cmake pkg-config build-essential chromium strace"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"

missing=""
for p in $DEB_PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "install: Debian packages:$missing"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q $missing
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "install: virtual environment .venv"
  if ! "$PY" -m venv .venv 2>/dev/null; then
    rm -rf .venv
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q python3-venv
    "$PY" -m venv .venv
  fi
  .venv/bin/python -m pip install -q --upgrade pip
fi

stamp=.venv/.ecostudy-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "install: ecostudy and its Python dependencies (editable)"
  .venv/bin/python -m pip install -q -e ".[test,docs]"
  touch "$stamp"
fi

if [ ! -f .pyomo/lib/libpynumero_ASL.so ]; then
  echo "install: PyNumero ASL library into .pyomo/"
  mkdir -p .pyomo
  PYOMO_CONFIG_DIR="$PWD/.pyomo" .venv/bin/python -m pyomo.contrib.pynumero.build \
    -DASL_INCLUDE_DIR=/usr/include/ampl-netlib-solvers \
    -DASL_LIBRARY=/usr/lib/$(gcc -print-multiarch)/libamplsolver.so > .pyomo/build.log 2>&1 \
    || { echo "install: PyNumero build failed, see .pyomo/build.log"; tail -20 .pyomo/build.log; exit 1; }
fi
