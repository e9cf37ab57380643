import math
import os
from pathlib import Path

import numpy as np
import pytest

from aaai.env import AnimalAIEnv
from aaai.levels.common import arena_walls, sphere
from aaai.spec import AgentPose, LevelSpec, ObjectSpec


def heading(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


def open_arena(*objects: ObjectSpec, agent=(0.0, 0.0, 0.0), **extra) -> LevelSpec:
    """A hand-made level: the 50 x 50 arena, the agent at ``agent`` (x, y, yaw), these objects."""
    foods = [o for o in objects if o.is_food]
    return LevelSpec(
        level=0,
        name="test",
        difficulty=0,
        seed=0,
        agent=AgentPose(*agent),
        objects=tuple(arena_walls((50.0, 50.0), 4.0)) + objects,
        max_food_reward=max([f.food_value for f in foods], default=0.0),
        **extra,
    )


@pytest.fixture
def make_env():
    envs = []

    def factory(**kwargs):
        kwargs.setdefault("rays", False)
        env = AnimalAIEnv(**kwargs)
        envs.append(env)
        return env

    yield factory
    for env in envs:
        env.close()


def processes_holding(text: str) -> set[int]:
    """Pids of other processes whose environment holds ``text`` (Linux /proc): every process a Ray
    instance starts inherits its private RAY_TMPDIR, so none may be left once it is shut down."""
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != os.getpid():
            try:
                if text.encode() in (entry / "environ").read_bytes():
                    found.add(int(entry.name))
            except OSError:
                continue
    return found


__all__ = ["heading", "open_arena", "processes_holding", "sphere"]


def needs(module: str, extra: str):
    """``module`` of the ``extra`` extra: skipped where it is not installed, but on CI (where
    make test installs every extra) imported, so that a missing extra fails instead of skipping."""
    if os.environ.get("CI"):
        import importlib

        return importlib.import_module(module)
    return pytest.importorskip(module, reason=f"needs the {extra} extra, which make test installs")
