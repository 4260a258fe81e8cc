"""What one side of a split run did (``SeamResult``): its log, its timing and its
exchanges, written as ``<side>_log.npz`` and ``<side>_metrics.json``."""

from __future__ import annotations

import dataclasses as dc
import json
import pathlib

import numpy as np


@dc.dataclass
class SeamResult:
    """What one side of a run did.

    Attributes:
        incidents: channel -> kind -> how many messages were clipped, held, ignored or
            skipped (``manta_drake.seam.errors.Incidents``).
        stopped: why the run ended before its duration (the battery at its cut-off), or "".
        run_id, peer_run_id: this side's and its peer's run ids (the handshake).
        failed: why the side failed after it had run (its one line), or "".
        failsafe: the controller's failsafe events (``seam.failsafe.FailsafeEvent`` as
            dicts): when it began, after how much silence, how long, how it ended.
    """

    who: str
    mode: str
    url: str
    sim_time_s: float
    wall_time_s: float  # from the first exchange with the peer to the end
    exchanges: int
    resends: int
    log: dict
    incidents: dict = dc.field(default_factory=dict)
    stopped: str = ""
    run_id: str = ""
    peer_run_id: str = ""
    failed: str = ""
    failsafe: list = dc.field(default_factory=list)

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else float("nan")

    def metrics(self) -> dict:
        return {
            "who": self.who,
            "mode": self.mode,
            "url": self.url,
            "run_id": self.run_id,
            "peer_run_id": self.peer_run_id,
            "status": "failed" if self.failed else "stopped" if self.stopped else "ok",
            "stopped": self.stopped,
            "failed": self.failed,
            "failsafe": self.failsafe,
            "sim_time_s": self.sim_time_s,
            "wall_time_s": self.wall_time_s,
            "real_time_factor": self.real_time_factor,
            "exchanges": self.exchanges,
            "resends": self.resends,
            "incidents": self.incidents,
        }

    def write(self, out_dir) -> pathlib.Path:
        """Writes ``<who>_log.npz`` and ``<who>_metrics.json`` into ``out_dir``."""
        out = pathlib.Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        # numpy's stub gives savez_compressed a keyword allow_pickle: bool beside **kwds, and
        # mypy matches a ** of arrays against that bool too (the arrays go to **kwds).
        np.savez_compressed(
            out / f"{self.who}_log.npz",
            **{k: np.asarray(v) for k, v in self.log.items()},  # type: ignore[arg-type]
        )
        (out / f"{self.who}_metrics.json").write_text(json.dumps(self.metrics(), indent=2) + "\n")
        return out

    def summary(self) -> str:
        """One line: times, mode, exchanges, re-sends, and what was clipped, held, ignored or
        skipped, and why the run stopped early, if it did."""
        incidents = "; ".join(
            f"{name}: " + ", ".join(f"{n} {kind}" for kind, n in kinds.items())
            for name, kinds in self.incidents.items()
        )
        return (
            f"{self.who}: {self.sim_time_s:.3f} s simulated in {self.wall_time_s:.2f} s "
            f"(real-time factor {self.real_time_factor:.2f}), {self.mode}, "
            f"{self.exchanges} exchanges, {self.resends} re-sends, over {self.url}"
            + (f"; {incidents}" if incidents else "")
            + (f"; failsafe {len(self.failsafe)} time(s)" if self.failsafe else "")
            + (f"; stopped {self.stopped}" if self.stopped else "")
        )
