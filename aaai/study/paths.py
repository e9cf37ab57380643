"""The path the body's trunk travels in a trial, in metres, measured alike for participants (as
they play) and for policies (from their replays).

The trunk is the body's base, its head. Its position over the floor (x, y) is sampled every
:data:`PATH_SECONDS` of simulated time (and at the trial's end) and the path is the sum of the
straight distances between samples: a policy that decides every 0.1 s and a participant whose keys
act every 0.02 s are measured on the same grid. One world unit is :data:`METRES_PER_UNIT` metres.
"""

from __future__ import annotations

import math
from pathlib import Path

from aaai.errors import ConfigError
from aaai.study.store import METRES_PER_UNIT

PATH_SECONDS = 0.1  # the trunk's position is sampled every 0.1 s of simulated time


class Odometer:
    """The trunk's path over a trial: ``at(step, x, y)`` after each step (``step`` the control steps
    since the reset, 0 for the reset itself), ``end(x, y)`` at the trial's end; ``metres``."""

    def __init__(self, control_dt: float = 0.02) -> None:
        self.every = max(1, round(PATH_SECONDS / control_dt))
        self.units = 0.0
        self.last: tuple[float, float] | None = None
        self.next_step = 0

    def reset(self) -> None:
        self.units, self.last, self.next_step = 0.0, None, 0

    def at(self, step: int, x: float, y: float) -> None:
        """Samples the position if ``step`` reached the next sample's time."""
        if step >= self.next_step:
            self.add(x, y)
            self.next_step = (step // self.every + 1) * self.every

    def end(self, x: float, y: float) -> None:
        self.add(x, y)

    def add(self, x: float, y: float) -> None:
        if self.last is not None:
            self.units += math.hypot(x - self.last[0], y - self.last[1])
        self.last = (x, y)

    @property
    def metres(self) -> float:
        return round(self.units * METRES_PER_UNIT, 3)


def replay_path(replay: dict, name: str = "replay") -> float:
    """The path in metres of the episode a replay holds, measured as it is run again; a replay that
    does not run as recorded is refused (ConfigError naming it), its path being another one's."""
    from aaai.scoring.replays import make_env, run_replay

    env = make_env(replay)
    inner = env.unwrapped
    odometer = Odometer(inner.control_dt)

    def sample(*_: object) -> None:
        position, _ = inner.body.head_pose()
        odometer.at(inner.steps, float(position[0]), float(position[1]))

    try:
        arena = Path(replay["arena"]["path"]) if replay.get("arena") else None
        result = run_replay(replay, env=env, arena=arena, on_reset=sample, on_step=sample)
    finally:
        env.close()
    if result.differences:
        raise ConfigError(
            f"{name}: it does not run as recorded ({result.differences[0]}); allowed: a replay of this version's levels"
        )
    odometer.end(result.final_pose["x"], result.final_pose["y"])
    return odometer.metres


__all__ = ["PATH_SECONDS", "Odometer", "replay_path"]
