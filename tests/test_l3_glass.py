"""L3, obstacles, by running physics: the transparent wall between the start and the green is
solid (the body walking into it stays on its side; a ray from the start to the green stops on it)
yet the camera sees the green through it; the green is reached round it (validate's path exists)
and the body on the far side eats it."""

import math

import numpy as np
import pybullet as p
import pytest
from test_behaviours import walk_north

from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.levels import validate
from aaai.spec.kinds import COLOURS


def glass_and_green(env):
    """The green's body and the transparent wall nearest it (the one hiding it)."""
    (green,) = [b for b, o in env.world.objects.items() if o.kind == "food_green"]
    spot = env.world.objects[green].position[:2]
    glass = min(
        (b for b, o in env.world.objects.items() if o.kind == "transparent_wall"),
        key=lambda b: math.dist(env.world.objects[b].position[:2], spot),
    )
    return glass, green


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l3_the_glass_is_in_the_way_and_the_body_walking_into_it_stays_on_its_side(make_env, difficulty):
    env = make_env(max_steps=5000)
    env.reset(seed=1, options={"level": 3, "difficulty": difficulty})
    glass, green = glass_and_green(env)
    start = env.body.head_pose()[0]
    food = env.world.objects[green].position
    hit = p.rayTest((*start[:2], 1.0), (*food[:2], 1.0), physicsClientId=env.client)[0]
    assert hit[0] == glass  # straight from the start to the green, the glass comes first
    face = env.world.objects[glass].position[1] - env.world.objects[glass].size[1] / 2  # its south face
    _, info, head = walk_north(env, start[0], food[1], steps=600)  # 12 s of trotting at it
    assert not info["fell"] and info["food_eaten"] == 0
    assert head[1] < face - HEAD_RADIUS + 0.1  # pressed against it at most, not through
    assert head[1] > face - HEAD_RADIUS - 3.0  # and it did walk up to it


@pytest.mark.parametrize("difficulty", [0, 10])
def test_l3_the_camera_sees_the_green_through_the_glass(make_env, difficulty):
    env = make_env(camera=True, camera_resolution=48)
    observation, _ = env.reset(seed=1, options={"level": 3, "difficulty": difficulty})
    glass, green = glass_and_green(env)
    colour = np.array(COLOURS["food_green"][:3]) * 255
    camera = observation["camera"].reshape(-1, 3).astype(float)
    greenish = np.linalg.norm(camera - colour, axis=1) < 60
    assert greenish.sum() >= 2  # the green, 23 ahead, through the glass


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("gap, eaten", [(-0.05, True), (0.05, False)])
def test_l3_the_green_is_reached_round_the_glass_and_eaten_from_the_far_side(make_env, difficulty, gap, eaten):
    env = make_env()
    env.reset(seed=1, options={"level": 3, "difficulty": difficulty})
    assert validate.check(env.level_spec) == []  # a way round the glass and the other obstacles exists
    glass, green = glass_and_green(env)
    x, y, z = env.world.objects[green].position
    head_z = env.body.head_pose()[0][2]
    reach = HEAD_RADIUS + env.world.objects[green].size[0] / 2 + gap
    north = y + math.sqrt(reach**2 - (head_z - z) ** 2)  # the head north of it, facing south
    p.resetBasePositionAndOrientation(
        env.body.id, (x, north, head_z), p.getQuaternionFromEuler((0, 0, -math.pi / 2)), physicsClientId=env.client
    )
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert info["food_eaten"] == int(eaten) and terminated == eaten
    if eaten:
        assert info["reward_terms"]["food"] == pytest.approx(env.level_spec.max_food_reward)
