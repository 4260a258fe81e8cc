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
# Another apt-get (a second bootstrap beside this one) holds apt's locks for a minute or two:
# wait for it (up to 10 min) instead of failing. `update` has no lock timeout of its own.
apt_install() {
  local try
  for try in $(seq 60); do
    if $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq 2>/tmp/ensure_debian.$$ \
        && $SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq "$package" >/dev/null \
          2>>/tmp/ensure_debian.$$; then
      rm -f /tmp/ensure_debian.$$; return 0
    fi
    grep -q 'Could not get lock' /tmp/ensure_debian.$$ || break
    [ "$try" = 1 ] && echo "apt is busy (another install); waiting for its lock ..."
    sleep 10
  done
  cat /tmp/ensure_debian.$$ >&2; rm -f /tmp/ensure_debian.$$; return 1
}
if ! apt_install </dev/null; then
  echo "error: apt-get could not install $package (see above)." >&2
  exit 1
fi
if ! present; then
  echo "error: $package installed but $what is still not found." >&2
  exit 1
fi
echo "installed $package ($(dpkg-query -W -f='${Version}' "$package" 2>/dev/null))"
