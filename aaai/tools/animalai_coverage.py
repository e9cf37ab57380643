"""The reference controller on imported Animal-AI arenas: an episode's pass rule and how many of a
folder's arena files the reference passes (``python -m aaai.tools.animalai FOLDER [SAMPLE]``)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from aaai.config import ConfigError
from aaai.scoring.evaluation import PASS_RATIO
from aaai.spec import LevelSpec

STEP_ALLOWANCE = 0.5  # the scoreboard's max reward is the food's best minus this (aaai.scoring.evaluation)


def passed(episode_return: float, spec: LevelSpec) -> bool:
    """Did an episode of this level pass? At or above the arena's pass mark (``extras["pass_mark"]``)
    when it has one, else the scoreboard's rule (return / max reward >= PASS_RATIO)."""
    mark = spec.extras.get("pass_mark")
    if mark is not None:
        return episode_return >= mark
    best = spec.max_food_reward - STEP_ALLOWANCE
    return best > 0 and episode_return / best >= PASS_RATIO


def reference_episode(env, spec: LevelSpec, seed: int) -> tuple[float, bool]:
    """One episode of the reference controller (aaai.task.reference) on a level: its return and
    whether it passed (:func:`passed`)."""
    from aaai.task.reference import ReferenceController

    observation, _ = env.reset(seed=seed, options={"spec": spec, "check": False})
    controller = ReferenceController(env)
    controller.reset(seed)
    total = 0.0
    while True:
        observation, reward, terminated, truncated, _ = env.step(controller(observation))
        total += reward
        if terminated or truncated:
            return total, passed(total, spec)


def coverage(folder: Path, sample: int = 0, seed: int = 0, echo: Callable[[str], object] = print) -> dict:
    """Of the arena files in ``folder`` (as ``import-animalai`` wrote them): how many load and pass
    aaai.levels.validate for ``seed``, and how many of those (every one, or ``sample`` of them spread
    evenly in name order) the reference controller passes in gait mode:
    ``python -m aaai.tools.animalai FOLDER [SAMPLE]``."""
    from aaai.env import AnimalAIEnv
    from aaai.task.arena import load_arena

    files = sorted(Path(folder).glob("*.yaml"))
    valid = []
    for file in files:
        try:
            valid.append((file, load_arena(file, seed)))
        except ConfigError:
            pass
    chosen = (
        valid
        if not sample or sample >= len(valid)
        else [valid[round(i * (len(valid) - 1) / (sample - 1))] for i in range(sample)]
        if sample > 1
        else valid[:1]
    )
    env = AnimalAIEnv(action_mode="gait")
    passes = 0
    try:
        for file, spec in chosen:
            total, ok = reference_episode(env, spec, seed)
            passes += ok
            echo(
                f"{file.name}: return {total:.2f}, pass mark {spec.extras.get('pass_mark')}, "
                f"{'passed' if ok else 'failed'}"
            )
    finally:
        env.close()
    result = {"files": len(files), "valid": len(valid), "run": len(chosen), "passed": passes}
    echo(
        f"{result['files']} arena files, {result['valid']} valid (seed {seed}), reference passed "
        f"{passes} of {len(chosen)} run"
    )
    return result
