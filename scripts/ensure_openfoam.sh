#!/usr/bin/env bash
# Installs Debian's OpenFOAM (v1912, package `openfoam`) only where simpleFoam is missing.
# The CFD study (manta-drake study cfd, make cfd) and its slow test need it. Quiet when done.
# The Debian binaries need WM_PROJECT_DIR=/usr/share/openfoam (manta_drake.studies.cfd.run sets it).
set -u
if command -v simpleFoam >/dev/null 2>&1 || [ -x /usr/bin/simpleFoam ]; then
  exit 0
fi
echo "OpenFOAM (simpleFoam) is missing; installing Debian's openfoam (about 100 MB, 1-2 min) ..."
SUDO=""
if [ "$(id -u)" != "0" ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
    echo "error: OpenFOAM is missing and this user cannot run apt-get (not root, no passwordless sudo)." >&2
    echo "       ask an administrator to run: apt-get install -y openfoam" >&2
    exit 1
  fi
fi
if ! command -v apt-get >/dev/null; then
  echo "error: OpenFOAM is missing and this machine has no apt-get; install OpenFOAM (simpleFoam, snappyHexMesh) with its package manager." >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
if ! { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq openfoam >/dev/null; } </dev/null; then
  echo "error: apt-get could not install openfoam (see above)." >&2
  exit 1
fi
if ! command -v simpleFoam >/dev/null 2>&1; then
  echo "error: openfoam installed but simpleFoam is not on PATH." >&2
  exit 1
fi
echo "installed openfoam ($(dpkg-query -W -f='${Version}' openfoam 2>/dev/null))"
