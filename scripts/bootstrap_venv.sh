#!/usr/bin/env bash
# Creates (or reuses) the virtual environment VENV with the Python PYTHON names and installs
# manta_drake editable with its test extra. Used by `make setup`.
#
#   bash scripts/bootstrap_venv.sh PYTHON VENV
#
# PYTHON may be a command (python3.12) or a path. A pyenv shim for a version pyenv does not
# have selected is resolved to that version's interpreter. A VENV made with another Python
# minor version is made anew (a venv cannot change its interpreter).
set -u
PYTHON=$1
VENV=$2

runs() { "$1" -c 'import sys; sys.exit(not (3, 11) <= sys.version_info[:2] <= (3, 13))' 2>/dev/null; }

if ! runs "$PYTHON" && command -v pyenv >/dev/null; then
  # e.g. python3.12 -> the newest installed 3.12.x of pyenv
  want=$(echo "$PYTHON" | sed -n 's/^python\([0-9]*\.[0-9]*\)$/\1/p')
  if [ -n "$want" ]; then
    version=$(pyenv versions --bare 2>/dev/null | grep -E "^${want//./\\.}(\.[0-9]+)?$" | sort -V | tail -1)
    if [ -n "$version" ] && runs "$(pyenv root)/versions/$version/bin/python$want"; then
      PYTHON="$(pyenv root)/versions/$version/bin/python$want"
    fi
  fi
fi
if ! runs "$PYTHON"; then
  echo "error: $1 is not a runnable Python 3.11, 3.12 or 3.13, which manta_drake needs (choose one with PYTHON=..., e.g. make test PYTHON=python3.12)" >&2
  exit 1
fi
want=$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [ -x "$VENV/bin/python" ]; then
  have=$("$VENV/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null || echo none)
  if [ "$have" != "$want" ]; then
    echo "$VENV has Python $have, $1 is $want: making $VENV anew ..."
    rm -rf "$VENV"
  fi
fi
# Done already: the venv has this Python and was installed after the last pyproject.toml.
if [ -x "$VENV/bin/python" ] && [ -f "$VENV/.installed" ] && [ "$(cat "$VENV/.installed")" = "$want" ] \
    && [ "$VENV/.installed" -nt pyproject.toml ]; then
  exit 0
fi
if [ ! -x "$VENV/bin/python" ]; then
  "$PYTHON" -m venv "$VENV" || { echo "error: $PYTHON -m venv $VENV failed" >&2; exit 1; }
fi
echo "installing manta_drake and its pinned dependencies into $VENV (Python $want) ..."
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[test]" 2>&1 \
  | grep -v "is ignored: it is neither"
"$VENV/bin/python" -c "import pydrake, open3d, manta_drake" \
  || { echo "error: the install into $VENV failed (see above)" >&2; exit 1; }
"$VENV/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])' > "$VENV/.installed"
