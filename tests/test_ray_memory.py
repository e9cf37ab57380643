"""`sensors.ray_memory`: what the rays showed of food 1, 2, 4 ... steps ago, by running physics."""

import numpy as np
import pybullet as p
import pytest
from conftest import open_arena, sphere

from aaai.config import ConfigError
from aaai.spec.kinds import KIND_INDEX

GREEN = KIND_INDEX["food_green"]
SENSES = dict(rays=True, rays_per_side=4, ray_max_angle=180.0, ray_length=50.0)


def food_out_of_sight(env):
    """Moves the level's one piece of food far below the floor: no ray sees it from now on."""
    (food,) = [body for body, obj in env.world.objects.items() if obj.kind == "food_green"]
    p.resetBasePositionAndOrientation(food, (0.0, 0.0, -50.0), (0, 0, 0, 1), physicsClientId=env.client)


def test_food_seen_once_is_recalled_exactly_1_2_4_and_8_steps_later(make_env):
    env = make_env(**SENSES, ray_memory=4)
    spec = open_arena(sphere("food_green", 8.0, 0.0, 4.0))
    first, _ = env.reset(options={"spec": spec})
    assert first["ray_memory"].shape == (4, 9, 3)
    assert not first["ray_memory"][:, :, :2].any() and (first["ray_memory"][:, :, 2] == 1.0).all()  # blank
    seen = first["rays"][:, GREEN] == 1.0
    assert seen.sum() >= 1
    food_out_of_sight(env)
    for step in range(1, 12):
        observation, *_ = env.step(env.body.rest_action())
        assert not observation["rays"][:, GREEN].any()
        memory = observation["ray_memory"]
        for slot, lag in enumerate((1, 2, 4, 8)):
            recalled = memory[slot, :, 0] == 1.0
            if lag == step:  # the rays of the first observation, with their distances
                np.testing.assert_array_equal(recalled, seen)
                np.testing.assert_array_equal(memory[slot, seen, 2], first["rays"][seen, -1])
            else:
                assert not recalled.any() and (memory[slot, :, 2] == 1.0).all(), (step, lag)


def test_a_reset_forgets_the_last_episode(make_env):
    env = make_env(**SENSES, ray_memory=2)
    spec = open_arena(sphere("food_green", 8.0, 0.0, 4.0))
    env.reset(options={"spec": spec})
    observation, *_ = env.step(env.body.rest_action())
    assert observation["ray_memory"][0, :, 0].any()
    observation, _ = env.reset(options={"spec": open_arena()})
    assert not observation["ray_memory"][:, :, :2].any()
    observation, *_ = env.step(env.body.rest_action())
    assert not observation["ray_memory"][:, :, :2].any()  # no food in this level, none remembered


def test_memory_works_with_flat_rays_and_the_down_fan(make_env):
    env = make_env(**SENSES, ray_memory=1, rays_flat=True, ray_down_fan=8.0)
    first, _ = env.reset(options={"spec": open_arena(sphere("food_green", 8.0, 0.0, 4.0))})
    observation, *_ = env.step(env.body.rest_action())
    assert observation["ray_memory"].shape == (1, 18, 3)
    np.testing.assert_array_equal(observation["ray_memory"][0, :, 0], first["rays"].reshape(18, -1)[:, GREEN])


def test_without_memory_there_is_no_key(make_env):
    observation, _ = make_env(**SENSES).reset(options={"spec": open_arena()})
    assert "ray_memory" not in observation


@pytest.mark.parametrize("bad", [-1, 11, 2.5, "4", True])
def test_a_bad_depth_is_refused_by_name(make_env, bad):
    with pytest.raises(ConfigError, match=r"sensors\.ray_memory.*allowed: an integer from 0 to 10"):
        make_env(**SENSES, ray_memory=bad)


def test_gymnasiums_checker_passes_with_memory_and_the_down_fan(make_env):
    from gymnasium.utils.env_checker import check_env

    check_env(make_env(**SENSES, ray_memory=3, ray_down_fan=8.0, action_mode="gait"), skip_render_check=True)
