#!/usr/bin/env bash
# Create .venv/ with Python 3.11 and the pinned dependencies (requirements.lock), and install the system
# libraries bpy and headless EEVEE need when they are missing (without EGL/Mesa the process aborts).
#
#   bash scripts/setup.sh                  full setup (what `make setup` runs)
#   bash scripts/setup.sh --print-missing  only list the missing Debian packages, install nothing
#
# Environment: PYTHON=/path/to/python3.11 picks the interpreter; SSGI_EXTRA_SYSTEM_PACKAGES adds packages.
set -euo pipefail
cd "$(dirname "$0")/.."

# Debian packages: what bpy's shared objects link against (ldd on bpy/__init__.so) and what a headless
# EEVEE render loads at run time (libEGL + Mesa's EGL driver + llvmpipe/swrast DRI driver); their own
# dependencies (libdrm, libllvm, libxcb-*, ...) come with them through apt.
SYSTEM_PACKAGES=(libx11-6 libxext6 libxrender1 libxfixes3 libxi6 libxxf86vm1 libxkbcommon0 libsm6 libice6
                 libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri)
# shellcheck disable=SC2206
SYSTEM_PACKAGES+=(${SSGI_EXTRA_SYSTEM_PACKAGES:-})

missing_packages() {
  local p
  if command -v dpkg-query >/dev/null; then
    for p in "${SYSTEM_PACKAGES[@]}"; do
      dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -q '^install ok installed$' || echo "$p"
    done
  fi
}

if [ "${1:-}" = "--print-missing" ]; then
  missing_packages
  exit 0
fi

say() { echo "setup: $*" >&2; }
T0=$(date +%s)

# --- system libraries ------------------------------------------------------------------------------------
if command -v dpkg-query >/dev/null; then
  mapfile -t need < <(missing_packages)
  if [ ${#need[@]} -gt 0 ]; then
    say "installing system libraries: ${need[*]}"
    SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq >&2 || say "apt-get update failed; trying the install with the package lists on disk"
    if ! $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >&2; then
      say "ERROR: could not install ${need[*]} (bpy and headless EEVEE need them); install them and run again"
      exit 1
    fi
  fi
else
  say "WARNING: not a Debian system; make sure libEGL, Mesa's EGL and DRI drivers, libGL, libX11, libXi,"
  say "         libXrender, libXfixes, libxkbcommon and libSM are installed (headless EEVEE aborts without EGL)"
fi

# --- Python 3.11 -------------------------------------------------------------------------------------------
is311() { "$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' >/dev/null 2>&1; }
PY=${PYTHON:-}
if [ -z "$PY" ]; then
  cands=(python3.11 python3)
  if command -v pyenv >/dev/null; then
    for v in $(pyenv versions --bare 2>/dev/null | grep -E '^3\.11(\.|$)' | sort -t. -k3 -n -r); do
      cands+=("$(pyenv root)/versions/$v/bin/python3.11")
    done
  fi
  for c in "${cands[@]}"; do
    if command -v "$c" >/dev/null && is311 "$c"; then PY=$c; break; fi
  done
fi
if [ -z "$PY" ] || ! is311 "$PY"; then
  say "ERROR: Python 3.11 is required (bpy 5.0.1 exists only for 3.11); set PYTHON=/path/to/python3.11"
  exit 1
fi

if [ -e .venv ] && ! is311 .venv/bin/python; then
  say ".venv exists but its python is not a working 3.11: making it again"
  rm -rf .venv
fi
if [ ! -x .venv/bin/python ]; then
  say "creating .venv with $PY ($("$PY" -c 'import sys; print(sys.executable)'))"
  "$PY" -m venv .venv
fi

# --- Python packages ---------------------------------------------------------------------------------------
# requirements.lock pins every package, torch==2.13.0+cpu included. On this machine kind pip finds that wheel
# in its configured local wheel folder; elsewhere it is on the PyTorch CPU index, tried when the first
# attempt fails.
PIP=(.venv/bin/python -m pip install --disable-pip-version-check --no-input -q)
# pip's "Location 'file:///...' is ignored: it is neither a file nor a directory" lines (one per package and
# configured local wheel folder that lacks it: about forty on this machine kind) are noise: hidden. Everything
# else pip writes to stderr (errors, other warnings) is shown, and pip's exit status is kept.
PIP_NOISE="^WARNING: Location '[^']*' is ignored: it is neither a file nor a directory\.\$"
quiet_pip() {
  local log rc=0
  log=$(mktemp)
  "${PIP[@]}" "$@" 2>"$log" || rc=$?
  grep -v -E "$PIP_NOISE" "$log" >&2 || true
  rm -f "$log"
  return "$rc"
}
if ! quiet_pip -r requirements.lock; then
  say "pip failed; trying again with the PyTorch CPU index for torch==2.13.0+cpu"
  quiet_pip --extra-index-url https://download.pytorch.org/whl/cpu -r requirements.lock
fi

# --- the wheels the extension zips bundle (blender_manifest.toml `wheels`, one zip per platform) ------------
# OpenEXR's Linux x86-64 wheel (1.7 MB) is committed; the others (onnxruntime's 14-24 MB each, OpenEXR's for the other
# platforms) are fetched here for the platform their file names carry, rather than kept in git, and checked against
# wheels/SHA256SUMS, so that `make build` packs the very files the tests ran with.
while read -r sum name; do
  [ -n "$name" ] || continue
  if [ ! -f "wheels/$name" ]; then
    pkg=$(echo "$name" | cut -d- -f1); ver=$(echo "$name" | cut -d- -f2)
    plat=$(basename "$name" .whl | rev | cut -d- -f1 | rev)  # the wheel's platform tag: win_amd64, macosx_14_0_arm64 ...
    say "fetching the bundled wheel $name"
    tmp=$(mktemp -d)
    .venv/bin/python -m pip download --disable-pip-version-check --no-input -q --no-deps --only-binary :all: \
      --platform "$plat" --python-version 3.11 -d "$tmp" "$pkg==$ver" 2> >(grep -v -E "$PIP_NOISE" >&2) \
      || { say "ERROR: could not download $pkg==$ver for $plat (the extension zips bundle it)"; exit 1; }
    mv "$tmp/$name" "wheels/$name" 2>/dev/null || { say "ERROR: pip gave $(ls "$tmp"), not wheels/$name"; exit 1; }
    rm -rf "$tmp"
  fi
  echo "$sum  wheels/$name" | sha256sum -c --quiet - || { say "ERROR: wheels/$name: sha256 differs from wheels/SHA256SUMS"; exit 1; }
done < wheels/SHA256SUMS

# --- checks --------------------------------------------------------------------------------------------
BPY_SO=$(.venv/bin/python -c 'import importlib.util as u, os; print(os.path.join(u.find_spec("bpy").submodule_search_locations[0], "__init__.so"))')
if ldd "$BPY_SO" | grep -q 'not found'; then
  say "ERROR: bpy needs system libraries that are missing:"; ldd "$BPY_SO" | grep 'not found' >&2; exit 1
fi
out=$(.venv/bin/python -c 'import bpy, torch, numpy, OpenEXR, onnx, onnxruntime; print("bpy", bpy.app.version_string, "torch", torch.__version__, "numpy", numpy.__version__, "onnxruntime", onnxruntime.__version__)' 2>&1) \
  || { say "ERROR: the new environment does not import:"; echo "$out" | grep -v EGL >&2; exit 1; }
say "$(echo "$out" | grep -v EGL | tail -1)"
touch .venv/.ssgi-setup-done
say "done in $(( $(date +%s) - T0 )) s; .venv uses $(du -sh .venv | cut -f1)"
