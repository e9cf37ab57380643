"""The sphere (agent.body: sphere) driven at full speed into a step: it rolls up one lower than its
radius, is stopped by one as high or higher, and is never thrown into the air or out of the arena
(its upward speed is capped, aaai.agent.sphere.rise_speed)."""

import math

import numpy as np
import pytest

from aaai.env import AnimalAIEnv
from aaai.levels.common import arena_walls
from aaai.spec import AgentPose, LevelSpec, ObjectSpec

# An imported arena (200 across: the sphere 5 across, 105 units/s) and the levels' (50: 1.25, 26 units/s).
# Along its path, in that arena's units: the start at 0.05, a block from 0.2 to 0.3, the arena's north wall
# at 0.5, of the arena's side.
IMPORTED, LEVELS = 200.0, 50.0
AHEAD = np.array([1.0, 0.0, 0.0], np.float32)


@pytest.fixture(scope="module")
def env():
    environment = AnimalAIEnv(body="sphere", rays=False)
    yield environment
    environment.close()


def _drive_at_a_step(env, arena: float, height: float):
    """Starts before a static block ``height`` high across the arena ``arena`` across and drives at it at
    full speed for 2.5 s (past it, to the arena's wall): the sphere's radius, its centre's track (n, 3),
    the last info."""
    near, far = 0.2 * arena, 0.3 * arena
    block = ObjectSpec("pillar", "box", (0.0, (near + far) / 2, height / 2), (arena, far - near, height))
    food = ObjectSpec("food_green", "sphere", (-0.4 * arena, -0.4 * arena, 1.5), (3.0, 3.0, 3.0))  # out of the way
    spec = LevelSpec(
        level=0,
        name="step",
        difficulty=0,
        seed=0,
        agent=AgentPose(0.0, 0.05 * arena, math.pi / 2),  # facing north, at the block
        objects=(*arena_walls((arena, arena), 4.0), block, food),
        max_food_reward=3.0,
        arena_size=(arena, arena),
    )
    env.reset(seed=0, options={"spec": spec, "check": False, "arena_file": True})
    track, info = [], {}
    for _ in range(25):
        _, _, terminated, truncated, info = env.step(AHEAD)
        track.append(env.body.head_pose()[0])
        if terminated or truncated:
            break
    return env.body.radius, np.array(track), info


def _inside(track, arena: float) -> bool:
    """Its centre never beyond the arena walls' faces (an impact at full speed sinks it in a little)."""
    return bool(np.all(np.abs(track[:, :2]) < arena / 2))


@pytest.mark.parametrize(("arena", "height"), [(IMPORTED, 1.5), (IMPORTED, 2.0), (LEVELS, 0.375)])
def test_a_step_lower_than_its_radius_is_rolled_up_without_a_jump(env, arena, height):
    radius, track, info = _drive_at_a_step(env, arena, height)
    assert radius == pytest.approx(arena / 80)  # 2.5 in the imported arena, 0.625 in the levels'
    on_block = (track[:, 1] > 0.2 * arena) & (track[:, 1] < 0.3 * arena)
    assert np.any(track[on_block, 2] >= height + radius - 0.1 * radius)  # up on the block
    # never more than its radius above what it rests on (without the cap its centre rose to 31 at 1.5)
    assert track[:, 2].max() <= height + 2 * radius
    assert _inside(track, arena) and not info["blew_up"]
    assert track[-1, 1] > arena / 2 - 1.2 * radius and track[-1, 2] < 1.05 * radius  # at the north wall, on the floor


@pytest.mark.parametrize(("arena", "height"), [(IMPORTED, 2.5), (IMPORTED, 3.0), (LEVELS, 0.75)])
def test_a_step_as_high_as_its_radius_stops_it(env, arena, height):
    radius, track, info = _drive_at_a_step(env, arena, height)
    assert track[:, 1].max() < 0.2 * arena - radius / 2  # held at the block's face (sunk in a little at the impact)
    assert track[:, 2].max() < 1.05 * radius  # on the floor all along
    assert _inside(track, arena) and not info["blew_up"]
