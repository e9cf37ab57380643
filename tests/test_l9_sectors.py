"""L9, numerosity, by running physics: the body goes into one sector (its door closes behind the
head) and is put head first to each piece there in turn. Every piece pays its value, the episode
ends with the sector's last piece, and only the one sector with the most food pays the level's
max_food_reward; every other sector pays less."""

import math

import pybullet as p
import pytest
from test_l1_foods import head_into

SECTORS = {"north": (0, 1), "east": (1, 0), "south": (0, -1), "west": (-1, 0)}


def sector_of(x: float, y: float) -> str:
    return next(name for name, (ux, uy) in SECTORS.items() if x * ux + y * uy > abs(y * ux - x * uy))


def eat_a_sector(env, name: str) -> tuple[float, bool]:
    """Enters the sector (past its door's trigger line), then eats its pieces one by one; returns
    what the food paid and whether the episode ended with the last piece and not before."""
    ux, uy = SECTORS[name]
    door = next(b for b in env.world.doors if tuple(env.world.objects[b].behaviour["direction"]) == (ux, uy))
    inside = env.world.objects[door].behaviour["distance"] + 1.0
    for _ in range(2):  # the door reads where the head was at the end of the step before
        p.resetBasePositionAndOrientation(
            env.body.id,
            (inside * ux, inside * uy, 1.5),
            p.getQuaternionFromEuler((0, 0, math.atan2(uy, ux))),
            physicsClientId=env.client,
        )
        _, _, terminated, _, info = env.step(env.body.rest_action())
    assert door not in env.world.doors  # shut behind the head
    pieces = [b for b in env.world.food if sector_of(*env.world.objects[b].position[:2]) == name]
    paid, ended = 0.0, terminated
    for count, body in enumerate(pieces, start=1):
        assert not ended
        value = env.world.objects[body].food_value
        head_into(env, body, -0.2)
        _, _, ended, truncated, info = env.step(env.body.rest_action())
        assert info["food_eaten"] == count and not truncated and not info["fell"]
        assert info["reward_terms"]["food"] == pytest.approx(value)
        paid += info["reward_terms"]["food"]
    return paid, ended


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l9_only_the_sector_with_the_most_food_pays_max_food_reward(make_env, difficulty):
    env = make_env()
    options = {"level": 9, "difficulty": difficulty}
    env.reset(seed=8, options=options)
    pays = {}
    for name in SECTORS:
        env.reset(seed=8, options=options)
        pays[name], ended = eat_a_sector(env, name)
        assert ended  # nothing left that can be got to
    best = max(pays.values())
    assert best == pytest.approx(env.level_spec.max_food_reward) and best > 0
    assert sorted(pays.values())[-2] < best  # strictly the most: one right choice
