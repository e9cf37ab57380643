"""Why a policy fails a level: its failed scoreboard episodes replayed, and what its senses showed.

A scoreboard row says that an episode failed, not why. This replays each failed episode of a
policy (the same seed and policy give the same episode, bit for bit) and records, per decision,
what the rays showed and where the body was, to sort the failure into one first cause:

- ``fell``: the body fell (off a platform, into a hole or pit, onto deadly floor);
- ``never saw food``: no ray ever hit a piece of food the episode could still pay for;
- ``lost sight``: it saw food, then spent the last third of the episode with none in view;
- ``saw, did not reach``: food was in view late in the episode but not eaten (the body got stuck,
  circled or walked into walls);
- ``ate the wrong food``: it ate, but not enough to pass (a green before the yellows, a smaller
  green).

``aaai diagnose --policy RUN --scoreboard CSV [--levels …]`` prints the table per level; the docs'
Learned agents page quotes it.
"""

from __future__ import annotations

import csv
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aaai.config import Config, env_part
from aaai.env import AnimalAIEnv
from aaai.scoring.episodes import play
from aaai.scoring.policies import Policy, as_policy
from aaai.spec.kinds import KIND_INDEX

FOOD_CHANNELS = (KIND_INDEX["food_green"], KIND_INDEX["food_yellow"])
RAY_WIDTH = 11  # the classic rays: nine kinds, nothing, distance
CAUSES = ("fell", "never saw food", "lost sight", "saw, did not reach", "ate the wrong food")


@dataclass(frozen=True)
class Failure:
    level: int
    difficulty: int
    seed: int
    cause: str
    seen_share: float  # decisions with food in view / decisions
    food_eaten: int
    wall_hits: int


def food_in_view(observation: dict) -> bool:
    rays = observation.get("rays")
    if rays is None:
        return False
    grid = rays if rays.ndim == 2 else rays.reshape(-1, RAY_WIDTH)  # rays_flat: one vector of rays x RAY_WIDTH
    return bool(grid[:, list(FOOD_CHANNELS)].any())


def replay_failure(env: AnimalAIEnv, policy, row: dict) -> Failure:
    level, difficulty, seed = int(row["level"]), int(row["difficulty"]), int(row["seed"])
    seen: list[bool] = []
    result = play(
        env,
        policy,
        seed,
        options={"level": level, "difficulty": difficulty},
        on_reset=lambda observation, info: seen.append(food_in_view(observation)),
        on_step=lambda step, observation, reward, info: seen.append(food_in_view(observation)),
    )
    info = result.info
    seen_array = np.array(seen)
    late = seen_array[len(seen_array) * 2 // 3 :]
    if info["fell"]:
        cause = "fell"
    elif info["food_eaten"] > 0:
        cause = "ate the wrong food"
    elif not seen_array.any():
        cause = "never saw food"
    elif not late.any():
        cause = "lost sight"
    else:
        cause = "saw, did not reach"
    return Failure(
        level, difficulty, seed, cause, float(seen_array.mean()), int(info["food_eaten"]), int(info["wall_hits"])
    )


def diagnose(
    policy: Policy | str, scoreboard: Path, config: Config, levels: list[int] | None = None, limit: int | None = None
) -> list[Failure]:
    """Replays the failed rows of ``scoreboard`` (of ``levels``; at most ``limit`` per level) with
    ``policy`` (a Policy, or a --policy string)."""
    policy = as_policy(policy)

    with open(scoreboard, newline="") as handle:
        rows = [
            r
            for r in csv.DictReader(handle)
            if r["outcome"] == "failed" and not r.get("arena") and (levels is None or int(r["level"]) in levels)
        ]
    if limit is not None:
        kept: list[dict] = []
        count: Counter[str] = Counter()
        for row in rows:
            if count[row["level"]] < limit:
                kept.append(row)
                count[row["level"]] += 1
        rows = kept
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        acting = policy.build(env)
        return [replay_failure(env, acting, row) for row in rows]
    finally:
        env.close()


def table_markdown(failures: list[Failure]) -> str:
    from aaai.levels import get_level

    lines = [
        "| level | failed episodes replayed | " + " | ".join(CAUSES) + " | food in view (share of decisions) |",
        "|---|---:|" + "---:|" * len(CAUSES) + "---:|",
    ]
    for level in sorted({f.level for f in failures}):
        mine = [f for f in failures if f.level == level]
        counts = Counter(f.cause for f in mine)
        lines.append(
            f"| {get_level(level).label} {get_level(level).name} | {len(mine)} | "
            + " | ".join(str(counts[c]) for c in CAUSES)
            + f" | {100 * np.mean([f.seen_share for f in mine]):.0f}% |"
        )
    return "\n".join(lines) + "\n"
