"""One episode of a policy: the loop that `aaai run`, `aaai eval` and `aaai show --video` share.

A policy is a callable from an observation to an action; one with a ``reset(seed)`` method is
reset to the episode's seed after the environment, and one with an ``end_episode(result)`` method
is handed the EpisodeResult when the loop ends (aaai.scoring.replays records episodes so).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable


@dataclass(frozen=True)
class EpisodeResult:
    episode_return: float  # the rewards summed
    steps: int  # env.step calls made
    observation: Any  # the last one
    info: dict  # the last step's (the reset's when no step was made)
    terminated: bool
    truncated: bool
    wall_seconds: float  # from before the reset to the end
    step_seconds: float  # the steps alone: from after the resets to the end

    @property
    def end(self) -> str | None:
        """Why the episode ended: "fell", "blew up", "ate green" (any other termination) or "time"
        (any other truncation); None if it had not ended when ``max_steps`` ran out."""
        if not (self.terminated or self.truncated):
            return None
        if self.info["fell"]:
            return "fell"
        if self.info["blew_up"]:
            return "blew up"
        return "ate green" if self.terminated else "time"


def play(
    env,
    policy: Callable,
    seed: int,
    options: dict | None = None,
    on_reset: Callable[[Any, dict], None] | None = None,
    on_step: Callable[[int, Any, float, dict], None] | None = None,
    max_steps: int | None = None,
) -> EpisodeResult:
    """Resets ``env`` to ``seed`` (with reset ``options``), then ``policy``, and steps until the
    episode ends or ``max_steps`` steps are made. ``on_reset(observation, info)`` is called after
    the env's reset, before the policy's; ``on_step(step, observation, reward, info)`` after each
    step (numbered from 1), the last one included."""
    started = time.perf_counter()
    observation, info = env.reset(seed=seed, options=options)
    if on_reset is not None:
        on_reset(observation, info)
    if hasattr(policy, "reset"):
        policy.reset(seed)
    stepping = time.perf_counter()
    total, steps, terminated, truncated = 0.0, 0, False, False
    while max_steps is None or steps < max_steps:
        observation, reward, terminated, truncated, info = env.step(policy(observation))
        steps += 1
        total += reward
        if on_step is not None:
            on_step(steps, observation, reward, info)
        if terminated or truncated:
            break
    ended = time.perf_counter()
    result = EpisodeResult(total, steps, observation, info, terminated, truncated, ended - started, ended - stepping)
    if hasattr(policy, "end_episode"):
        policy.end_episode(result)
    return result
