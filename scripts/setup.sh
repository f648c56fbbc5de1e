#!/usr/bin/env bash
# Install everything railfem needs on a fresh Debian 12 machine (run as root).
#
# Idempotent: Debian packages are installed only when missing, and the Python
# package is (re)installed in editable mode with the test extra.
#
#   bash scripts/setup.sh                  # uses python3
#   PYTHON=/tmp/venv/bin/python bash scripts/setup.sh
#   SKIP_APT=1 bash scripts/setup.sh       # skip the Debian package step
#
# Facts behind the package list (measured on bare Debian 12):
#   * the gmsh wheel fails at import without the X/GL libraries below;
#   * headless VTK (pyvista off-screen) needs libegl1 together with
#     VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow (railfem.rendering sets it).
#   * Debian's own python3 is "externally managed" (PEP 668): pip refuses to install into
#     it unless given --break-system-packages, which is added for that interpreter only
#     (never inside a virtual environment); python3-pip is apt-installed when it lacks pip.
set -euo pipefail

PYTHON="${PYTHON:-python3}"
DEB_PACKAGES=(libglu1-mesa libgl1 libxcursor1 libxft2 libxinerama1 libgomp1 libegl1)

log() { printf '[setup] %s\n' "$*"; }

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO_ROOT"
log "repository root: $REPO_ROOT"

install_debian_packages() {
    local missing=() pkg
    for pkg in "${DEB_PACKAGES[@]}"; do
        if dpkg -s "$pkg" >/dev/null 2>&1; then
            log "debian package present: $pkg"
        else
            log "debian package missing: $pkg"
            missing+=("$pkg")
        fi
    done
    if [ "${#missing[@]}" -eq 0 ]; then
        log "all debian packages present; skipping apt-get"
        return 0
    fi
    if [ "$(id -u)" -ne 0 ]; then
        log "ERROR: missing debian packages (${missing[*]}) and not root;" \
            "run as root or: sudo apt-get install -y ${missing[*]}"
        return 1
    fi
    log "apt-get update"
    DEBIAN_FRONTEND=noninteractive apt-get update -q
    log "apt-get install ${missing[*]}"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# Debian's system interpreter without pip: let apt provide it.
if command -v "$PYTHON" >/dev/null 2>&1 && ! "$PYTHON" -m pip --version >/dev/null 2>&1 \
        && [[ "$(readlink -f "$(command -v "$PYTHON")")" == /usr/bin/python3* ]]; then
    DEB_PACKAGES+=(python3-pip)
fi

if [ "${SKIP_APT:-0}" = "1" ]; then
    log "SKIP_APT=1: not checking debian packages"
elif command -v dpkg >/dev/null 2>&1; then
    install_debian_packages
else
    log "dpkg not found (not Debian?); skipping system packages"
fi

if ! command -v "$PYTHON" >/dev/null 2>&1; then
    log "ERROR: python interpreter '$PYTHON' not found; set PYTHON=/path/to/python3"
    exit 1
fi
log "python: $("$PYTHON" -c 'import sys; print(sys.executable, sys.version.split()[0])')"

PIP_FLAGS=(--disable-pip-version-check -q)
if "$PYTHON" -c 'import os, sys, sysconfig
managed = os.path.exists(os.path.join(sysconfig.get_path("stdlib"), "EXTERNALLY-MANAGED"))
sys.exit(0 if managed and sys.prefix == sys.base_prefix else 1)'; then
    log "$PYTHON is externally managed (PEP 668): installing with --break-system-packages"
    PIP_FLAGS+=(--break-system-packages)
fi
log "pip install -e .[test]"
"$PYTHON" -m pip install "${PIP_FLAGS[@]}" -e ".[test]"

log "verifying imports (gmsh, pyvista, skfem)"
if [ -z "${DISPLAY:-}" ]; then
    export VTK_DEFAULT_OPENGL_WINDOW="${VTK_DEFAULT_OPENGL_WINDOW:-vtkEGLRenderWindow}"
fi
"$PYTHON" -c "import gmsh, pyvista, skfem; print('[setup] gmsh', gmsh.__version__, '| pyvista', pyvista.__version__, '| scikit-fem', skfem.__version__)"
log "done"
