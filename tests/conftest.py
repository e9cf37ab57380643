import math
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

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


def reference_on_arena(make_env, folder, text: str):
    """An env in gait mode reset on the arena file ``text`` (seed 0, written into ``folder``) and the
    reference controller reset on it: (env, controller)."""
    from aaai.task.arena import load_arena
    from aaai.task.reference import ReferenceController

    path = folder / "arena.yaml"
    path.write_text(text)
    env = make_env(action_mode="gait")
    env.reset(seed=0, options={"spec": load_arena(path, 0), "check": False})
    controller = ReferenceController(env)
    controller.reset(0)
    return env, controller


@pytest.fixture(scope="module")
def gait_env():
    """One env of a module in gait mode with the default senses (17 rays over 90 degrees)."""
    env = AnimalAIEnv(config={"agent": {"action_mode": "gait"}})
    yield env
    env.close()


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


# --- the command line as a user runs it ------------------------------------------------------
AAAI = [sys.executable, "-m", "aaai_cli.main"]


def aaai(*args, check=True):
    """``aaai *args`` in a process of its own; an AssertionError with its output if it fails (and ``check``)."""
    result = subprocess.run([*AAAI, *map(str, args)], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise AssertionError(f"aaai {' '.join(map(str, args))} failed:\n{result.stdout}\n{result.stderr}")
    return result


def aaai_here(*args, check=True):
    """``aaai(*args)`` run in this process by click's runner (no interpreter and imports to start again);
    the same returncode, stdout and stderr."""
    from aaai_cli.main import cli

    result = CliRunner().invoke(cli, list(map(str, args)))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    if check and result.exit_code != 0:
        raise AssertionError(f"aaai {' '.join(map(str, args))} failed:\n{result.output}")
    return SimpleNamespace(returncode=result.exit_code, stdout=result.stdout, stderr=result.stderr)


# Animal-AI arena YAML, as its competition files write items (x, z on the floor; y up): an agent
# (turned by ``r`` degrees), a wall of floor size (sx, sz), 2 high, and a good goal 1 across.
AAI_AGENT = (
    "    - !Item\n      name: Agent\n      positions: [!Vector3 {{x: {x}, y: 0, z: {z}}}]\n      rotations: [{r}]\n"
)
AAI_WALL = (
    "    - !Item\n      name: Wall\n      positions: [!Vector3 {{x: {x}, y: 0, z: {z}}}]\n"
    "      sizes: [!Vector3 {{x: {sx}, y: 2, z: {sz}}}]\n      rotations: [0]\n"
)
AAI_GOAL = (
    "    - !Item\n      name: GoodGoal\n      positions: [!Vector3 {{x: {x}, y: 0, z: {z}}}]\n"
    "      sizes: [!Vector3 {{x: 1, y: 1, z: 1}}]\n"
)
