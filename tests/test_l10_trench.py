"""L10, causal reasoning, by running physics: the trench is missing floor right across the arena
between the start and the green (probed straight down a hair either side of both its edges, from
one side wall of the arena to the other); the body walking into it away from the plank falls and
the episode ends with the fall's cost; the side walls by the plank stop what is thrown at them,
transparent or not. (The plank pushed over bridging the trench, and the same walk failing without
it: test_behaviours.test_the_l10_plank_pushed_over_bridges_the_trench; the search finding the
green only over the plank: test_levels_all.test_the_l10_trench_is_crossable_only_by_the_plank.)"""

import math

import numpy as np
import pybullet as p
import pytest
from test_behaviours import walk_north

from aaai.sim.world import DEADLY_FLOOR_TOP
from aaai.spec.kinds import KIND_INDEX

HAIR = 0.05
FLOOR, DROP = KIND_INDEX["floor"], KIND_INDEX["deadly_floor"]


def below(env, x: float, y: float) -> int:
    """The kind a ray straight down at (x, y) meets first (-1: nothing)."""
    body = p.rayTest((x, y, 3.0), (x, y, DEADLY_FLOOR_TOP - 1.0), physicsClientId=env.client)[0][0]
    return -1 if body < 0 else int(env.world.kind_index[body])


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l10_the_trench_runs_right_across_between_the_start_and_the_green(make_env, difficulty):
    env = make_env()
    env.reset(seed=9, options={"level": 10, "difficulty": difficulty})
    south, north = env.level_spec.extras["trench"]
    half = env.level_spec.arena_size[0] / 2
    for x in np.arange(-half + 0.25, half, 0.5):  # every half unit from one arena wall to the other
        assert below(env, x, south - HAIR) == FLOOR, x
        assert below(env, x, south + HAIR) == DROP, x
        assert below(env, x, (south + north) / 2) == DROP, x
        assert below(env, x, north - HAIR) == DROP, x
        assert below(env, x, north + HAIR) == FLOOR, x
    assert env.body.head_pose()[0][1] < south - 3.0  # the start on the near side
    (green,) = env.world.food
    assert env.world.objects[green].position[1] > north  # the green on the far side


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l10_walking_into_the_trench_away_from_the_plank_falls_with_the_fall_cost(make_env, difficulty):
    env = make_env(max_steps=5000)
    env.reset(seed=9, options={"level": 10, "difficulty": difficulty})
    south, north = env.level_spec.extras["trench"]
    (plank,) = [o for o in env.world.objects.values() if o.kind == "plank"]
    lane = -15.0 if plank.position[0] > 0 else 15.0
    p.resetBasePositionAndOrientation(
        env.body.id,
        (lane, south - 10.0, 1.5),
        p.getQuaternionFromEuler((0, 0, math.pi / 2)),
        physicsClientId=env.client,
    )
    _, info, head = walk_north(env, lane, north + 3.0)
    assert info["fell"] and info["reward_terms"]["fall"] == -1.0
    assert env.steps < env.max_steps  # the episode ended there
    assert south - 3.0 < head[1] < north + 3.0  # in the trench, not beyond it


@pytest.mark.parametrize("difficulty, seed", [(4, 0), (4, 1), (8, 2), (10, 3), (10, 9)])
def test_l10_a_side_wall_stops_a_ball_thrown_at_it_transparent_or_not(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 10, "difficulty": difficulty})
    (plank,) = [o for o in env.world.objects.values() if o.kind == "plank"]
    walls = [
        o
        for o in env.world.objects.values()
        if o.kind in ("wall", "transparent_wall") and abs(o.position[0]) < 24 and abs(o.position[1]) < 24
    ]
    assert walls  # a side wall from difficulty 4
    for wall in walls:
        side = np.sign(wall.position[0] - plank.position[0])  # the lane is on the plank's side of it
        face = wall.position[0] - side * 0.5  # the wall's face toward the lane
        ball = p.createMultiBody(
            1.0,
            p.createCollisionShape(p.GEOM_SPHERE, radius=0.5, physicsClientId=env.client),
            basePosition=(face - side * 2.0, wall.position[1], 1.0),
            physicsClientId=env.client,
        )
        p.resetBaseVelocity(ball, (side * 15.0, 0.0, 0.0), physicsClientId=env.client)
        for _ in range(50):  # one simulated second
            env.step(env.body.rest_action())
        x = p.getBasePositionAndOrientation(ball, physicsClientId=env.client)[0][0]
        assert side * (face - x) >= 0.5 - HAIR, (wall.kind, x, face)  # bounced off its face, not through
        p.removeBody(ball, physicsClientId=env.client)
