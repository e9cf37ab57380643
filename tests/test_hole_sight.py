"""Missing floor in the rays: a hole is seen where its edge is, to within 0.2, and only within the
rays' reach. Tested by running physics: teleport the body to face a hole, let it stand, read the
forward ray and compare with the distance from the ray's origin to the hole's near edge."""

import numpy as np
import pytest
from conftest import open_arena

from aaai.sim.sensors import EYE_OFFSET
from aaai.spec.kinds import KIND_INDEX

HOLE = KIND_INDEX["hole"]
LENGTH = 20.0
SIGHT = dict(rays=True, rays_per_side=4, ray_max_angle=90.0, ray_length=LENGTH)
FORWARD = 4  # the middle ray of 2 x 4 + 1
EDGE = 5.0  # 5 x 5 tiles of 10 over the 50 x 50 arena: tile (3, 2) spans x 5..15, y -5..5


def beside_the_hole(make_env, agent, stand_steps: int = 25):
    """An arena of 5 x 5 tiles missing tile (3, 2), the body set down at ``agent`` (x, y, yaw) with
    rays only, left to stand ``stand_steps`` control steps: the env and its observation."""
    env = make_env(**SIGHT)
    observation, _ = env.reset(options={"spec": open_arena(agent=agent, tiles=(5, 5), holes=((3, 2),)), "check": False})
    for _ in range(stand_steps):
        observation, *_ = env.step(env.body.rest_action())
    return env, observation


def facing_the_hole(make_env, x: float):
    """The forward ray and the true distance from its origin along it to the hole's near edge, the
    body placed at (x, 0) facing +x and left to stand for half a second."""
    env, observation = beside_the_hole(make_env, (x, 0.0, 0.0))
    position, rotation = env.body.head_pose()
    forward = rotation[:, 0]
    origin = position + forward * EYE_OFFSET
    true_distance = (EDGE - origin[0]) / forward[0]  # along the ray, to where its ground track meets x = 5
    return observation["rays"][FORWARD], true_distance


@pytest.mark.parametrize("x", [-10.0, -5.0, -1.0])
def test_a_hole_is_seen_at_its_true_distance_within_two_tenths(make_env, x):
    ray, true_distance = facing_the_hole(make_env, x)
    assert ray[HOLE] == 1.0 and ray[:-1].sum() == 1.0  # the hole and nothing else
    assert ray[-1] * LENGTH == pytest.approx(true_distance, abs=0.2)


@pytest.mark.parametrize("beyond", [-0.2, 0.2])
def test_a_hole_a_hair_beyond_the_rays_reach_is_not_seen(make_env, beyond):
    """The near edge 0.2 inside the reach is seen (at 0.99 of it); 0.2 beyond it, the ray sees nothing."""
    _, offset = facing_the_hole(make_env, 0.0)  # how far ahead of the body's x the origin stands
    origin_ahead = EDGE - offset
    ray, true_distance = facing_the_hole(make_env, EDGE - LENGTH - beyond - origin_ahead)
    assert true_distance == pytest.approx(LENGTH + beyond, abs=0.05)  # the probe is where it is meant to be
    assert bool(ray[HOLE]) == (beyond < 0)
    if beyond < 0:
        assert ray[-1] * LENGTH == pytest.approx(true_distance, abs=0.2)
    else:
        assert ray[-1] == 1.0  # nothing within reach


def ground_track_distance(start, direction, box, reach=LENGTH, step=0.001):
    """How far along ``direction`` (per unit of the 3-d ray) the ray's ground track from ``start``
    first lies inside ``box`` (x0, y0, x1, y1), found by walking it; None within ``reach``."""
    t = np.arange(0.0, reach, step)
    x, y = start[0] + t * direction[0], start[1] + t * direction[1]
    inside = (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])
    return float(t[inside.argmax()]) if inside.any() else None


@pytest.mark.parametrize("where", [(-1.0, -8.0, 0.0), (-2.0, 9.0, -0.3), (20.0, -9.0, 2.6)])
def test_every_ray_sees_the_hole_where_its_ground_track_enters_it(make_env, where):
    """Oblique rays too: each of the nine rays of a fan over +-90 degrees that passes over the hole
    reports it at the distance where its ground track enters it (to 0.01, found by walking the
    track, not by the sensor's slab arithmetic), entering by an x side or a y side; the others
    report no hole."""
    env, observation = beside_the_hole(make_env, where)
    position, rotation = env.body.head_pose()
    directions = env.rays.local_dirs @ rotation.T
    starts = position + directions * EYE_OFFSET
    seen = 0
    for ray, start, direction in zip(observation["rays"], starts, directions):
        distance = ground_track_distance(start, direction, (EDGE, -EDGE, 15.0, EDGE))
        if distance is None:
            assert ray[HOLE] == 0.0
        else:
            seen += 1
            assert ray[HOLE] == 1.0 and ray[-1] * LENGTH == pytest.approx(distance, abs=0.01)
    assert seen >= 2


def test_a_head_over_the_edge_sees_the_hole_at_once(make_env):
    """The body set down with its head's rays starting over the gap: the hole at distance 0."""
    env, observation = beside_the_hole(make_env, (4.0, 0.0, 0.0), stand_steps=0)
    position, rotation = env.body.head_pose()
    origin = position + rotation[:, 0] * EYE_OFFSET
    assert EDGE < origin[0] < 15.0  # the forward ray starts over the gap
    ray = observation["rays"][FORWARD]
    assert ray[HOLE] == 1.0 and ray[-1] == 0.0
