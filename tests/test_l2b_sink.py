"""L2b, delayed gratification, by running physics: the yellow on the pillar is out of the head's
reach from the floor until the pillar has sunk (in the sink time the level itself gives), then it
is eaten where the pillar stood without ending the episode; the green after it ends the episode,
and the two together pay the level's max_food_reward."""

import math

import numpy as np
import pybullet as p
import pytest

from aaai.agent.urdf_writer import HEAD_RADIUS

STAND = 1.5  # the head's height standing at rest


def bodies_of(env, kind):
    return [body for body, obj in env.world.objects.items() if obj.kind == kind]


def hold_head(env, x: float, y: float, yaw: float) -> None:
    """The body held by hand: its head put at (x, y) at standing height, at rest."""
    p.resetBasePositionAndOrientation(
        env.body.id, (x, y, STAND), p.getQuaternionFromEuler((0, 0, yaw)), physicsClientId=env.client
    )
    p.resetBaseVelocity(env.body.id, (0, 0, 0), (0, 0, 0), physicsClientId=env.client)


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l2b_the_yellow_is_eaten_from_the_floor_only_once_the_pillar_has_sunk(make_env, difficulty):
    env = make_env(max_steps=5000)
    env.reset(seed=3, options={"level": "L2b", "difficulty": difficulty})
    (pillar,), (yellow,) = bodies_of(env, "pillar"), bodies_of(env, "food_yellow")
    (green,) = bodies_of(env, "food_green")
    seconds = env.world.objects[pillar].behaviour["duration"]  # the sink time, as the level was built
    x, y, _ = env.world.objects[pillar].position
    piece = env.world.objects[yellow]
    radius = piece.size[0] / 2
    # the head a hair inside touching where the yellow will rest on the floor, coming from the south
    reach = HEAD_RADIUS + radius - 0.05
    eaten_at = None
    for step in range(1, round(seconds / env.control_dt) + 50):
        hold_head(env, x, y - reach, math.pi / 2)
        _, _, terminated, truncated, info = env.step(env.body.rest_action())
        assert not truncated
        if info["food_eaten"]:
            eaten_at = step * env.control_dt
            assert info["reward_terms"]["food"] == pytest.approx(piece.food_value)
            assert not terminated  # the yellow does not end the episode
            break
        assert not terminated
    assert eaten_at is not None, "the yellow never came within reach"
    # only in the last few percent of the sink (the head reaches 0.55 above its own height), in time
    assert 0.9 * seconds < eaten_at <= seconds + env.control_dt, (eaten_at, seconds)
    paid = info["reward_terms"]["food"]
    # the green after it, straight ahead of the start
    gx, gy, gz = env.world.objects[green].position
    reach = HEAD_RADIUS + env.world.objects[green].size[0] / 2 - 0.05
    hold_head(env, gx, gy - math.sqrt(reach**2 - (STAND - gz) ** 2), math.pi / 2)
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert terminated and info["food_eaten"] == 2
    assert paid + info["reward_terms"]["food"] == pytest.approx(env.level_spec.max_food_reward)


def test_l2b_the_green_is_straight_ahead_of_the_start_and_the_yellow_off_to_a_side(make_env):
    """The choice the level puts: walking straight ahead reaches the green, not the pillar."""
    env = make_env()
    for seed in range(4):
        env.reset(seed=seed, options={"level": "L2b", "difficulty": 5})
        (green,), (pillar,) = bodies_of(env, "food_green"), bodies_of(env, "pillar")
        head, rotation = env.body.head_pose()
        forward = rotation[:2, 0] / np.linalg.norm(rotation[:2, 0])
        to_green = np.array(env.world.objects[green].position[:2]) - head[:2]
        assert abs(forward[0] * to_green[1] - forward[1] * to_green[0]) < 0.1  # on the heading's line
        to_pillar = np.array(env.world.objects[pillar].position[:2]) - head[:2]
        off = abs(forward[0] * to_pillar[1] - forward[1] * to_pillar[0])
        assert off > HEAD_RADIUS + env.world.objects[pillar].size[0] / 2  # the straight walk passes it
