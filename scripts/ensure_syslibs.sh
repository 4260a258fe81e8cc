#!/usr/bin/env bash
# Installs Debian's libusb-1.0-0 (open3d links against it) only where the loader lacks it.
set -u
if ldconfig -p 2>/dev/null | grep -q 'libusb-1\.0\.so'; then
  exit 0
fi
echo "libusb-1.0 is missing (open3d needs it); installing Debian's libusb-1.0-0 ..."
SUDO=""
if [ "$(id -u)" != "0" ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
    echo "error: libusb-1.0 is missing and this user cannot run apt-get (not root, no passwordless sudo)." >&2
    echo "       ask an administrator to run: apt-get install -y libusb-1.0-0" >&2
    exit 1
  fi
fi
if ! command -v apt-get >/dev/null; then
  echo "error: libusb-1.0 is missing and this machine has no apt-get; install libusb-1.0 with its package manager." >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
if ! { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq libusb-1.0-0 >/dev/null; } </dev/null; then
  echo "error: apt-get could not install libusb-1.0-0 (see above)." >&2
  exit 1
fi
echo "installed libusb-1.0-0"
