"""sensors.ray_width: each ray cast again w/2 to its left and right, the nearest hit winning (an
approximation of Animal-AI's 0.5 sphere casts)."""

import math

import numpy as np
import pytest
from conftest import open_arena

from aaai.config import ConfigError
from aaai.levels.common import slab


def post_seen(env, angle: float) -> bool:
    post = slab("wall", 10.0 * math.cos(angle), 10.0 * math.sin(angle), 0.3, 0.3, 4.0)
    observation, _ = env.reset(options={"spec": open_arena(post)})
    sees_wall = observation["rays"][:, 2] == 1.0
    near = observation["rays"][:, -1] * 15 < 10.0  # nearer than the arena's walls
    return bool((sees_wall & near).any())


@pytest.mark.parametrize("between", [True, False])
def test_a_thin_post_between_two_rays_is_seen_with_wide_rays(make_env, between):
    """A post 0.3 wide, 10 away, midway between two rays 0.98 apart there: thin rays miss it,
    rays 1.0 wide (+-0.5, Animal-AI's sphere radius) see it; on a ray both see it."""
    step = math.radians(45.0 / 8)
    angle = step / 2 if between else step
    assert post_seen(make_env(rays=True, ray_width=1.0), angle)
    assert post_seen(make_env(rays=True), angle) == (not between)


def test_wide_rays_keep_the_shape_and_report_the_nearest_of_their_hits(make_env):
    thin, wide = make_env(rays=True), make_env(rays=True, ray_width=1.0)
    spec = open_arena(slab("wall", 8.0, 0.6, 0.3, 0.3, 4.0))  # beside the forward ray, within 0.5 of it
    a, _ = thin.reset(options={"spec": spec})
    b, _ = wide.reset(options={"spec": spec})
    assert a["rays"].shape == b["rays"].shape
    forward = b["rays"][8]
    assert forward[2] == 1.0 and 5.0 < forward[-1] * 15 < 8.0  # the post, measured from the eye ahead of x = 0
    assert a["rays"][8][2] == 0.0 and a["rays"][8][-1] > forward[-1]  # the thin ray passes the post by
    empty, _ = wide.reset(options={"spec": open_arena()})
    plain, _ = thin.reset(options={"spec": open_arena()})
    assert np.allclose(empty["rays"][:, :-1], plain["rays"][:, :-1])


def test_a_bad_ray_width_is_refused_by_name(make_env):
    with pytest.raises(ConfigError, match="ray_width"):
        make_env(rays=True, ray_width=-1.0)


def test_wide_rays_work_with_the_pitched_down_fan(make_env):
    env = make_env(rays=True, ray_width=1.0, ray_down_fan=8.0)
    observation, _ = env.reset(options={"spec": open_arena()})
    assert observation["rays"].shape == (34, 11) and env.rays.local_sides.shape == (34, 3)
    assert np.allclose(np.linalg.norm(env.rays.local_sides, axis=1), 0.5)  # level, across each ray
