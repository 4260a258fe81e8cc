"""How the seam reports trouble: ``SeamError`` when it cannot go on (a silent peer, a
malformed message, a URL that cannot open), ``warn`` for a notice while it goes on."""

import sys


class SeamError(RuntimeError):
    """The seam failed: a peer is silent, a message is malformed, a URL cannot open."""


def warn(message: str) -> None:
    """One line on stderr, flushed at once (the other side's operator reads it live)."""
    print(message, file=sys.stderr, flush=True)
