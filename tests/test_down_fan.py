"""`sensors.ray_down_fan`: the same fan of rays again, pitched down, for food lower than the head.

The head walks about 2.3 above the floor, so rays in its plane pass over food smaller than that:
on reserved L0 d8-10 (size-2 food) the reference's episodes show the food to level rays in about
1 % of their decisions. Tested by running physics: teleport, step, read the rays."""

import math

import numpy as np
import pytest
from conftest import open_arena, sphere

from aaai.config import ConfigError
from aaai.sim.sensors import EYE_OFFSET
from aaai.spec.kinds import KIND_INDEX

GREEN, FLOOR = KIND_INDEX["food_green"], KIND_INDEX["floor"]
FAN = dict(rays=True, rays_per_side=4, ray_max_angle=180.0, ray_length=50.0)


def settled(env, spec, steps=25):
    """The body's rays after it has stood for ``steps`` control steps (its walking height)."""
    observation, _ = env.reset(options={"spec": spec})
    for _ in range(steps):
        observation, *_ = env.step(env.body.rest_action())
    return observation["rays"]


def head_height(make_env) -> float:
    env = make_env(**FAN)
    settled(env, open_arena())
    return float(env.body.head_pose()[0][2])


@pytest.mark.parametrize("above", [0.3, -0.3])
def test_level_rays_see_food_taller_than_the_head_and_pass_over_food_lower(make_env, above):
    """A hair either side of the head's height: food whose top is 0.3 above it is seen, 0.3 below not."""
    size = head_height(make_env) + above
    rays = settled(make_env(**FAN), open_arena(sphere("food_green", 12.0, 0.0, size)))
    assert bool(rays[4, GREEN]) == (above > 0)


def test_the_down_fan_sees_food_lower_than_the_head_where_it_is(make_env):
    spec = open_arena(sphere("food_green", 8.0, 0.0, head_height(make_env) - 0.3))
    level = settled(make_env(**FAN), spec)
    both = settled(make_env(**FAN, ray_down_fan=8.0), spec)
    n = 9  # rays per fan: 4 a side and one forward, from right to left; the forward one is row 4
    assert level.shape == (n, 11) and both.shape == (2 * n, 11)
    assert not level[:, GREEN].any()  # the level fan sees no food at all
    np.testing.assert_array_equal(both[:n], level)  # the level fan is unchanged by the second
    forward_down = both[n + 4]
    assert forward_down[GREEN] == 1.0 and both[n:, GREEN].sum() == 1.0  # only the forward down ray
    along = forward_down[-1] * 50.0 + EYE_OFFSET  # from the head's centre, along the pitched ray
    radius = spec.objects[-1].size[0] / 2
    assert 8.0 - radius - 0.2 <= along * math.cos(math.radians(8.0)) <= 8.0  # the sphere's near side


@pytest.mark.parametrize("pitch", [4.0, 8.0, 16.0])
def test_the_down_fan_meets_the_floor_where_its_pitch_says(make_env, pitch):
    """An empty arena: every ray of the lower fan ends on the floor at height / sin(pitch)."""
    env = make_env(**FAN, ray_down_fan=pitch)
    rays = settled(env, open_arena())
    height = env.body.head_pose()[0][2]
    expected = height / math.sin(math.radians(pitch)) - EYE_OFFSET
    lower = rays[9:]
    assert (lower[:, FLOOR] == 1.0).all()
    # the head tilts a little as the body stands: within a tenth of the distance
    np.testing.assert_allclose(lower[:, -1] * 50.0, expected, rtol=0.12)
    assert (rays[:9, FLOOR] == 0.0).all()  # the level fan never meets the floor


def test_flat_rays_keep_both_fans_row_by_row(make_env):
    spec = open_arena(sphere("food_green", 8.0, 0.0, 1.0))
    grid = settled(make_env(**FAN, ray_down_fan=8.0), spec)
    flat = settled(make_env(**FAN, ray_down_fan=8.0, rays_flat=True), spec)
    np.testing.assert_array_equal(flat, grid.reshape(-1))


@pytest.mark.parametrize("bad", [-1, 45.5, float("nan"), "8", True])
def test_a_bad_pitch_is_refused_by_name(make_env, bad):
    with pytest.raises(ConfigError, match=r"sensors\.ray_down_fan.*allowed: a number from 0 to 45"):
        make_env(**FAN, ray_down_fan=bad)
