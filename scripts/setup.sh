#!/usr/bin/env bash
# Create .venv/ with Python 3.11 and the pinned dependencies (requirements.lock), and install the system
# EGL/Mesa libraries headless EEVEE needs when they are missing (without them the process aborts).
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-}
if [ -z "$PY" ]; then
  for c in python3.11 python3; do
    if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then PY=$c; break; fi
  done
fi
if [ -z "$PY" ]; then
  echo "setup: Python 3.11 is required (bpy 5.0.1 exists only for 3.11); set PYTHON=/path/to/python3.11" >&2
  exit 1
fi

# System libraries for headless EEVEE (Mesa EGL + llvmpipe) and bpy's X/GL dependencies.
need=()
ldconfig -p | grep -q 'libEGL_mesa.so' || need+=(libegl-mesa0)
ldconfig -p | grep -q 'libEGL.so.1' || need+=(libegl1)
[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
ldconfig -p | grep -q 'libxkbcommon.so.0' || need+=(libxkbcommon0)
ldconfig -p | grep -q 'libSM.so.6' || need+=(libsm6)
ldconfig -p | grep -q 'libXi.so.6' || need+=(libxi6)
ldconfig -p | grep -q 'libXxf86vm.so.1' || need+=(libxxf86vm1)
ldconfig -p | grep -q 'libXfixes.so.3' || need+=(libxfixes3)
ldconfig -p | grep -q 'libXrender.so.1' || need+=(libxrender1)
if [ ${#need[@]} -gt 0 ]; then
  echo "setup: installing system libraries: ${need[*]}" >&2
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq && $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >&2
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $PY" >&2
  "$PY" -m venv .venv
fi
# torch==2.13.0 (CPU build) is taken from the local wheel folder on this machine kind; elsewhere pip would
# fetch the CUDA build of the same version.
.venv/bin/python -m pip install --disable-pip-version-check -q -r requirements.lock
.venv/bin/python -c 'import bpy, torch, numpy, OpenEXR; print("setup: bpy", bpy.app.version_string, "torch", torch.__version__, "numpy", numpy.__version__)' 2>&1 | grep -v EGL >&2
touch .venv/.ssgi-setup-done
