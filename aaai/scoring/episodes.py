"""One episode of a policy: the loop that `aaai run`, `aaai eval` and `aaai show --video` share.

A policy is a callable from an observation to an action; one with a ``reset(seed)`` method is
reset to the episode's seed after the environment, and one with an ``end_episode(result)`` method
is handed the EpisodeResult when the loop ends (aaai.scoring.replays records episodes so).

:func:`run_episode` plays one episode of a scoreboard's cell (or arena file) and makes its row. An
episode's ratio is return / max_reward, where max_reward is the best food reward that level
instance can give minus 0.5 (allowing for step costs). Outcome: failed (ratio < 0.8), passed
(0.8 <= ratio < 1) or succeeded (ratio >= 1), as in the original build.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from aaai.env import AnimalAIEnv
from aaai.task.arena import load_arena

PASS_RATIO, SUCCESS_RATIO = 0.8, 1.0


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


def outcome(ratio: float, episode_return: float | None = None, pass_mark: float | None = None) -> str:
    """failed, passed or succeeded. With an arena's own ``pass_mark`` (Animal-AI's passMark, as
    aaai.tools.animalai.passed reads it) the return at or above it passes instead of the 0.8 ratio."""
    if pass_mark is not None and episode_return is not None:
        if episode_return < pass_mark:
            return "failed"
        return "succeeded" if ratio >= SUCCESS_RATIO else "passed"
    if ratio >= SUCCESS_RATIO:
        return "succeeded"
    return "passed" if ratio >= PASS_RATIO else "failed"


def run_episode(
    env: AnimalAIEnv, policy: Callable, level: int, difficulty: int, seed: int, arena: Path | None = None
) -> dict:
    """Plays one episode of the cell (or of the arena file, with the seed) to its end; its scoreboard row."""
    pass_mark = None
    options: dict[str, Any]
    if arena is None:
        options = {"level": level, "difficulty": difficulty}
    else:
        spec = load_arena(arena, seed, body=env.config.agent.body)
        options = {"spec": spec, "check": False, "arena_file": True}  # checked on load; the sphere sized to it
        level, difficulty = spec.level, spec.difficulty
        pass_mark = (spec.extras or {}).get("pass_mark")
    result = play(env, policy, seed, options=options)
    total, info = result.episode_return, result.info
    ratio = total / info["max_reward"] if info["max_reward"] > 0 else math.nan
    return {
        "level": level,
        "level_name": info["level_name"],
        "difficulty": difficulty,
        "seed": seed,
        "return": round(total, 6),
        "max_reward": round(info["max_reward"], 6),
        "ratio": round(ratio, 6),
        "outcome": outcome(ratio, total, pass_mark),
        "steps": info["steps"],
        "max_steps": info["max_steps"],
        "food_eaten": info["food_eaten"],
        "wall_hits": info["wall_hits"],
        "fell": info["fell"],
        "arena": arena.name if arena is not None else "",
        "wall_seconds": round(result.wall_seconds, 3),
    }
