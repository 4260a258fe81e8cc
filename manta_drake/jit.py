"""numba's ``njit`` for the package's compiled kernels, with a cache that never stops an import.

``njit(cache=True)`` keeps the machine code in the ``__pycache__`` folder beside the
kernel's file or in numba's user-wide cache (``$XDG_CACHE_HOME`` or ``~/.cache``;
``NUMBA_CACHE_DIR`` overrides both). In a read-only install with no writable home (a
service account, a container, a remote Dask worker) numba finds no such folder and raises
"cannot cache function ...: no locator available" at import, even for ``--help``. Here the
kernels then cache in a per-user folder under the system's temporary directory, or, if
that is not writable either, compile in each process without a cache (a few seconds).
"""

from __future__ import annotations

import os
import pathlib
import tempfile
from collections.abc import Callable
from typing import Any

import numba


def _temporary_cache_dir() -> str | None:
    """A writable per-user cache folder under the temporary directory, or None."""
    folder = pathlib.Path(tempfile.gettempdir()) / f"manta_drake-numba-{os.getuid()}"
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return None
    return str(folder)


def njit(
    function: Callable[..., Any] | None = None, /, *, cache: bool = False, **options: Any
) -> Callable[..., Any]:
    """``numba.njit`` (used as ``@njit(cache=True)``) that falls back from an unavailable
    cache to a temporary one, then to none, instead of failing."""
    if function is not None:  # bare @njit
        return numba.njit(function, cache=cache, **options)

    def decorate(function: Callable[..., Any]) -> Callable[..., Any]:
        if not cache:
            return numba.njit(**options)(function)
        try:
            return numba.njit(cache=True, **options)(function)
        except RuntimeError as e:
            if "no locator available" not in str(e):
                raise
        # numba reads its user-provided cache folder at decoration time; set it only when
        # the user has not chosen one (then numba had no folder at all). numba.config sets
        # its options as module globals at run time, which its typing does not declare.
        if not numba.config.CACHE_DIR:  # type: ignore[attr-defined]
            folder = _temporary_cache_dir()
            if folder is not None:
                numba.config.CACHE_DIR = folder  # type: ignore[attr-defined]
                try:
                    return numba.njit(cache=True, **options)(function)
                except RuntimeError:
                    pass
        return numba.njit(**options)(function)

    return decorate
