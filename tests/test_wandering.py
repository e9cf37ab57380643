"""Wandering food (the random_walk behaviour, L1) stays inside the arena: walkers are moved by
hand, not by physics, so the arena's edge is only kept by the walk's own rule. Tested by running
physics from a corner, and by probing the rule a hair either side of the edge."""

from dataclasses import replace

import numpy as np
import pybullet as p
import pytest
from conftest import open_arena

from aaai.levels.common import sphere

SIZE = 2.0  # the food's diameter
HALF = 25.0 - SIZE / 2  # how far from the centre its centre may go in the 50 x 50 arena


def wanderer(x: float, y: float, speed: float = 10.0):
    return replace(sphere("food_green", x, y, SIZE), behaviour={"type": "random_walk", "speed": speed})


@pytest.mark.parametrize("seed", [0, 2])
def test_wandering_food_started_in_a_corner_never_leaves_the_arena(make_env, seed):
    env = make_env(rays=False, max_steps=2000)
    spec = open_arena(wanderer(HALF - 0.5, HALF - 0.5), agent=(-15.0, -15.0, 0.0))
    env.reset(seed=seed, options={"spec": replace(spec, seed=seed), "check": False})  # start out of reach
    (food,) = [body for body, obj in env.world.objects.items() if obj.kind == "food_green"]
    farthest, travelled, last = 0.0, 0.0, None
    for _ in range(1500):  # 30 s at 10 units/s: many times across the arena's corner
        _, _, terminated, truncated, _ = env.step(env.body.rest_action())
        x, y, _ = p.getBasePositionAndOrientation(food, physicsClientId=env.client)[0]
        farthest = max(farthest, abs(x), abs(y))
        travelled += 0.0 if last is None else float(np.hypot(x - last[0], y - last[1]))
        last = (x, y)
        if terminated or truncated:  # wandered into the body and eaten
            break
    assert travelled > 100.0  # it did wander
    assert farthest <= HALF + 1e-9  # and never past the edge, less its radius
    assert farthest > HALF - 1.0  # it went up to the edge


@pytest.mark.parametrize("hair, blocked", [(-0.01, False), (0.01, True)])
def test_the_walk_turns_back_a_hair_past_the_arena_edge_less_its_radius(make_env, hair, blocked):
    env = make_env(rays=False)
    env.reset(options={"spec": open_arena(wanderer(0.0, 10.0))})
    for x, y in ((HALF + hair, 0.0), (-HALF - hair, 0.0), (0.0, HALF + hair), (0.0, -HALF - hair)):
        assert env.world.blocked(x, y, SIZE / 2) is blocked, (x, y)
