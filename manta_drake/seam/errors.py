"""How the seam reports trouble: ``SeamError`` when it cannot go on (a silent peer, a peer
that does not match, a URL that cannot open), ``PeerStopped`` when the peer ended the run
early on purpose, ``warn`` for a notice while it goes on, and ``Incidents`` for messages it
clips, holds, ignores or skips: each kind named once per channel, every one counted."""

from __future__ import annotations

import sys


class SeamError(RuntimeError):
    """The seam failed: a peer is silent or does not match, a URL cannot open.

    Attributes:
        result: what the side did before it failed (a ``SeamResult``, written like a
            finished side's), or None.
    """

    def __init__(self, *args, result=None):
        super().__init__(*args)
        self.result = result


class PeerStopped(SeamError):
    """The peer ended the run early on purpose (the station's battery at its cut-off): this
    side ends too, normally, with the peer's reason."""


def warn(message: str) -> None:
    """One line on stderr, flushed at once (the other side's operator reads it live)."""
    print(message, file=sys.stderr, flush=True)


class Incidents:
    """What one side clipped, held, ignored or skipped, by channel and kind.

    The first message of each kind on a channel is named in one line on stderr; later ones
    are only counted (a NaN storm at 1 kHz must not flood the operator's terminal), and the
    counts go into the side's result (``<side>_metrics.json``, the summary line).

    Kinds: ``clipped`` (a command beyond the servos' or the pump's limits, sent on at the
    limit), ``held`` (a non-finite command or reading, replaced by the last good one),
    ``ignored`` (a reading outside its physical range, treated as a dropped reading),
    ``dropout`` (a NaN reading, which the sensor sends for a failed reading), ``malformed``
    (a message that does not decode, skipped).
    """

    def __init__(self, who: str):
        self.who = who
        self.counts: dict[str, dict[str, int]] = {}

    def report(self, channel: str, kinds, text: str) -> None:
        """Counts one message with problems of ``kinds`` on ``channel``; names them in one line
        (``text``) unless each kind has been named on that channel before."""
        kinds = tuple(dict.fromkeys(kinds))
        seen = self.counts.setdefault(channel, {})
        new = [k for k in kinds if k not in seen]
        for kind in kinds:
            seen[kind] = seen.get(kind, 0) + 1
        if new:
            warn(
                f"{self.who}: {channel}: {text} (further {'/'.join(kinds)} messages on "
                f"{channel} are counted, not shown)"
            )

    def count(self, channel: str | None = None, kind: str | None = None) -> int:
        """How many messages had a problem (of ``kind``, on ``channel``; None: any)."""
        return sum(
            n
            for name, kinds in self.counts.items()
            if channel in (None, name)
            for k, n in kinds.items()
            if kind in (None, k)
        )
