"""What one side of a split run did (``SeamResult``): its log, its timing and its
exchanges, written as ``<side>_log.npz`` and ``<side>_metrics.json``."""

from __future__ import annotations

import dataclasses as dc
import json
import pathlib

import numpy as np


@dc.dataclass
class SeamResult:
    """What one side of a run did."""

    who: str
    mode: str
    url: str
    sim_time_s: float
    wall_time_s: float  # from the first exchange with the peer to the end
    exchanges: int
    resends: int
    log: dict

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else float("nan")

    def metrics(self) -> dict:
        return {"who": self.who, "mode": self.mode, "url": self.url,
                "sim_time_s": self.sim_time_s, "wall_time_s": self.wall_time_s,
                "real_time_factor": self.real_time_factor, "exchanges": self.exchanges,
                "resends": self.resends}

    def write(self, out_dir) -> pathlib.Path:
        """Writes ``<who>_log.npz`` and ``<who>_metrics.json`` into ``out_dir``."""
        out = pathlib.Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out / f"{self.who}_log.npz",
                            **{k: np.asarray(v) for k, v in self.log.items()})
        (out / f"{self.who}_metrics.json").write_text(json.dumps(self.metrics(), indent=2) + "\n")
        return out

    def summary(self) -> str:
        return (f"{self.who}: {self.sim_time_s:.3f} s simulated in {self.wall_time_s:.2f} s "
                f"(real-time factor {self.real_time_factor:.2f}), {self.mode}, "
                f"{self.exchanges} exchanges, {self.resends} re-sends, over {self.url}")
