#!/usr/bin/env bash
# Installs a Debian package the project needs only where it is missing; quiet when present.
#
#   bash scripts/ensure_debian.sh libusb     # libusb-1.0-0: open3d links against it
#   bash scripts/ensure_debian.sh openfoam   # OpenFOAM v1912: the CFD study and its slow test
#
# (The Debian OpenFOAM binaries need WM_PROJECT_DIR=/usr/share/openfoam, which
# manta_drake.studies.cfd.run sets.)
set -u
case "${1:-}" in
  libusb)
    package=libusb-1.0-0; what="libusb-1.0 (open3d needs it)"
    present() { ldconfig -p 2>/dev/null | grep -q 'libusb-1\.0\.so'; } ;;
  openfoam)
    package=openfoam; what="OpenFOAM's simpleFoam (the CFD study needs it; about 100 MB, 1-2 min)"
    present() { command -v simpleFoam >/dev/null 2>&1; } ;;
  *)
    echo "usage: bash scripts/ensure_debian.sh libusb|openfoam" >&2
    exit 2 ;;
esac
present && exit 0
echo "$what is missing; installing Debian's $package ..."
SUDO=""
if [ "$(id -u)" != "0" ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
    echo "error: $package is missing and this user cannot run apt-get (not root, no passwordless sudo)." >&2
    echo "       ask an administrator to run: apt-get install -y $package" >&2
    exit 1
  fi
fi
if ! command -v apt-get >/dev/null; then
  echo "error: $package is missing and this machine has no apt-get; install it with its package manager." >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
if ! { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq "$package" >/dev/null; } </dev/null; then
  echo "error: apt-get could not install $package (see above)." >&2
  exit 1
fi
if ! present; then
  echo "error: $package installed but $what is still not found." >&2
  exit 1
fi
echo "installed $package ($(dpkg-query -W -f='${Version}' "$package" 2>/dev/null))"
