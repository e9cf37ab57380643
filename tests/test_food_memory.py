"""`sensors.food_memory`: where the rays last showed each piece of food, carried with the body; by
running physics: see a piece, teleport the body or the piece, then assert."""

import math

import numpy as np
import pybullet as p
import pytest
from conftest import open_arena, sphere

from aaai.config import ConfigError

SENSES = dict(rays=True, rays_per_side=4, ray_max_angle=45.0, ray_length=50.0, ray_down_fan=8.0)
PRESENT, GREEN, YELLOW, AHEAD, LEFT, SIZE, AGE = range(7)


def turn_body(env, yaw: float) -> None:
    """Teleports the body to face ``yaw`` where it stands."""
    position, _ = p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.client)
    p.resetBasePositionAndOrientation(
        env.body.id, position, p.getQuaternionFromEuler((0.0, 0.0, yaw)), physicsClientId=env.client
    )


def head_xy(env) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.client)[0][:2])


def test_a_piece_in_view_is_slot_0_where_it_is_with_age_0(make_env):
    env = make_env(**SENSES, food_memory=2)
    observation, _ = env.reset(options={"spec": open_arena(sphere("food_green", 10.0, 0.0, 4.0))})
    memory = observation["food_memory"]
    assert memory.shape == (2, 7) and env.observation_space["food_memory"].contains(memory)
    assert memory[0, PRESENT] == memory[0, GREEN] == 1.0 and memory[0, YELLOW] == 0.0
    ahead = (10.0 - head_xy(env)[0]) / 50.0
    assert memory[0, AHEAD] == pytest.approx(ahead, abs=1e-3) and memory[0, LEFT] == pytest.approx(0.0, abs=1e-3)
    assert memory[0, SIZE] == pytest.approx(4.0 / 10.0) and memory[0, AGE] == 0.0
    assert not memory[1].any()  # one piece: the second slot is empty


def test_a_piece_out_of_view_is_kept_and_turned_with_the_body(make_env):
    env = make_env(**SENSES, food_memory=1)
    env.reset(options={"spec": open_arena(sphere("food_green", 10.0, 0.0, 4.0))})
    turn_body(env, math.pi / 2)  # facing +y: the piece on the right, outside the 90-degree fan
    for step in range(1, 4):
        observation, *_ = env.step(env.body.rest_action())
        assert not observation["rays"][:, GREEN].any()  # (the rays' green channel is column 1)
        memory = observation["food_memory"][0]
        head = head_xy(env)
        yaw = math.atan2(*reversed(_forward(env)))
        dx, dy = 10.0 - head[0], 0.0 - head[1]
        assert memory[PRESENT] == 1.0
        assert memory[AHEAD] == pytest.approx((math.cos(yaw) * dx + math.sin(yaw) * dy) / 50.0, abs=1e-3)
        assert memory[LEFT] == pytest.approx((-math.sin(yaw) * dx + math.cos(yaw) * dy) / 50.0, abs=1e-3)
        assert memory[LEFT] < -0.15  # on the right
        assert memory[AGE] == pytest.approx(step * env.control_dt / 60.0, rel=1e-4)


def test_a_moving_piece_out_of_view_is_expected_where_its_motion_carries_it(make_env):
    env = make_env(**SENSES, food_memory=1)
    env.reset(options={"spec": open_arena(sphere("food_green", 10.0, 0.0, 4.0))})
    (food,) = env.world.food
    p.resetBasePositionAndOrientation(food, (10.0, 0.5, 2.0), (0, 0, 0, 1), physicsClientId=env.client)
    env.step(env.body.rest_action())  # seen again 0.5 further on, one control step later: its velocity
    speed = 0.5 / env.control_dt
    p.resetBasePositionAndOrientation(food, (0.0, 20.0, -50.0), (0, 0, 0, 1), physicsClientId=env.client)
    turn_body(env, math.pi)  # facing away: no ray passes where it should be
    for step in (1, 2, 3):
        observation, *_ = env.step(env.body.rest_action())
        head, forward = head_xy(env), _forward(env)
        expected_y = 0.5 + speed * step * env.control_dt
        dx, dy = 10.0 - head[0], expected_y - head[1]
        left = (-forward[1] * dx + forward[0] * dy) / np.hypot(*forward)
        assert observation["food_memory"][0, LEFT] == pytest.approx(left / 50.0, abs=2e-3), step


def _forward(env) -> np.ndarray:
    orientation = p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.client)[1]
    return np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)[:2, 0]


def test_a_piece_a_ray_should_have_hit_is_forgotten(make_env):
    env = make_env(**SENSES, food_memory=1)
    env.reset(options={"spec": open_arena(sphere("food_green", 10.0, 0.0, 4.0))})
    (food,) = env.world.food
    p.resetBasePositionAndOrientation(food, (0.0, 20.0, -50.0), (0, 0, 0, 1), physicsClientId=env.client)
    observation, *_ = env.step(env.body.rest_action())  # the forward ray passes where it was: nothing there
    assert not observation["food_memory"].any()


def test_a_piece_behind_a_wall_is_never_remembered(make_env):
    from aaai.spec import ObjectSpec

    wall = ObjectSpec("wall", "box", (7.0, 0.0, 2.5), (1.0, 20.0, 5.0))
    env = make_env(**SENSES, food_memory=1)
    observation, _ = env.reset(options={"spec": open_arena(sphere("food_green", 12.0, 0.0, 4.0), wall)})
    assert not observation["food_memory"].any()


def test_pieces_are_listed_nearest_first_and_a_reset_forgets(make_env):
    env = make_env(**dict(SENSES, rays_per_side=16), food_memory=3)
    spec = open_arena(sphere("food_yellow", 20.0, 4.0, 6.0), sphere("food_green", 9.0, -2.0, 4.0))
    observation, _ = env.reset(options={"spec": spec})
    memory = observation["food_memory"]
    assert memory[:, PRESENT].tolist() == [1.0, 1.0, 0.0]
    assert memory[0, GREEN] == 1.0 and memory[1, YELLOW] == 1.0  # the green is nearer
    assert memory[0, SIZE] == pytest.approx(0.4) and memory[1, SIZE] == pytest.approx(0.6)
    assert memory[0, LEFT] < 0 < memory[1, LEFT] and memory[0, AHEAD] < memory[1, AHEAD]
    observation, _ = env.reset(options={"spec": open_arena()})
    assert not observation["food_memory"].any()


def test_a_reset_starts_as_a_new_environment_does(make_env):
    """What the last episode saw is gone, even where the rays of the new one cannot look (behind a wall)."""
    from aaai.spec import ObjectSpec

    wall = ObjectSpec("wall", "box", (7.0, 0.0, 2.5), (1.0, 20.0, 5.0))
    behind = open_arena(sphere("food_green", -12.0, 0.0, 4.0), wall)
    used = make_env(**SENSES, food_memory=2)
    used.reset(options={"spec": open_arena(sphere("food_green", 12.0, 0.0, 4.0))})
    used.step(used.body.rest_action())
    again, _ = used.reset(options={"spec": behind})
    fresh, _ = make_env(**SENSES, food_memory=2).reset(options={"spec": behind})
    np.testing.assert_array_equal(again["food_memory"], fresh["food_memory"])
    assert not again["food_memory"].any()


def test_without_it_there_is_no_key(make_env):
    observation, _ = make_env(**SENSES).reset(options={"spec": open_arena()})
    assert "food_memory" not in observation


@pytest.mark.parametrize("bad", [-1, 17, 2.5, "4", True])
def test_a_bad_count_is_refused_by_name(make_env, bad):
    with pytest.raises(ConfigError, match=r"sensors\.food_memory.*allowed: an integer from 0 to 16"):
        make_env(**SENSES, food_memory=bad)


def test_gymnasiums_checker_passes_with_it(make_env):
    from gymnasium.utils.env_checker import check_env

    check_env(make_env(**SENSES, food_memory=2, action_mode="gait"), skip_render_check=True)
