"""An example open-loop policy: a trot from phase-shifted sinusoids, sent as ordinary actions.

Diagonal legs (front-left with back-right, front-right with back-left) move together. Each
leg's hip up/down axis lifts it during the swing half of the cycle; its knee sideways axis
sweeps the foot forward in the swing and back in the stance, which pushes the body along.
Sweeping all feet the same way round turns the body on the spot instead.
"""
from __future__ import annotations

import math

import numpy as np

LEG_PHASE = {"fl": 0.0, "br": 0.0, "fr": math.pi, "bl": math.pi}
# +1 where a growing sideways angle moves that foot backward (legs lie on the diagonals).
BACKWARD_SIGN = {"fl": 1.0, "fr": -1.0, "bl": 1.0, "br": -1.0}
DIRECTIONS = ("forward", "backward", "left", "right")


class SineGait:
    """Callable policy: ``action = gait(observation)``; call ``reset()`` at each episode start."""

    def __init__(self, joint_names: list[str], direction: str = "forward", control_dt: float = 0.02,
                 frequency: float = 2.0, stance_down: float = 0.5, lift: float = 0.5, sweep: float = 0.4):
        if direction not in DIRECTIONS:
            raise ValueError(f"direction: got {direction!r}; allowed: one of {', '.join(DIRECTIONS)}")
        self.joint_names = list(joint_names)
        self.direction = direction
        self.control_dt = control_dt
        self.frequency, self.stance_down, self.lift, self.sweep = frequency, stance_down, lift, sweep
        self.step_count = 0

    @classmethod
    def for_env(cls, env, direction: str = "forward", **kwargs) -> "SineGait":
        base = env.unwrapped
        return cls(base.body.joint_names, direction, base.control_dt, **kwargs)

    def reset(self, seed: int | None = None) -> None:
        """Restarts the cycle (the seed is unused: the gait has no randomness)."""
        self.step_count = 0

    def _sweep_sign(self, leg: str) -> float:
        if self.direction == "forward":
            return BACKWARD_SIGN[leg]
        if self.direction == "backward":
            return -BACKWARD_SIGN[leg]
        return -1.0 if self.direction == "left" else 1.0

    def __call__(self, observation=None) -> np.ndarray:
        t = self.step_count * self.control_dt
        self.step_count += 1
        action = np.zeros(len(self.joint_names), np.float32)
        for i, name in enumerate(self.joint_names):
            leg, joint = name.split("_")[:2]
            phase = 2 * math.pi * self.frequency * t + LEG_PHASE[leg]
            if joint == "hip" and not name.endswith("_sideways"):  # hip up/down: lift in the swing
                action[i] = self.stance_down - self.lift * max(0.0, math.sin(phase))
            elif joint == "knee" and not name.endswith("_updown"):  # knee sideways: sweep the foot
                action[i] = self._sweep_sign(leg) * self.sweep * math.cos(phase)
        return action
