"""`sensors.sweep_memory`: where the rays have looked, in sectors round the body; by running physics:
look, teleport or turn the body, then assert."""

import math

import numpy as np
import pybullet as p
import pytest
from conftest import open_arena

from aaai.config import ConfigError
from aaai.spec import ObjectSpec

SENSES = dict(rays=True, rays_per_side=8, ray_max_angle=45.0, ray_length=15.0)
NEAR, MIDDLE, FAR = range(3)
AHEAD, LEFT, BEHIND, RIGHT = 0, 2, 4, 6  # of 8 sectors, counted round to the left from straight ahead


def teleport(env, x: float, y: float, yaw: float) -> None:
    position, _ = p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.client)
    p.resetBasePositionAndOrientation(
        env.body.id, (x, y, position[2]), p.getQuaternionFromEuler((0.0, 0.0, yaw)), physicsClientId=env.client
    )


def test_the_fan_looks_over_what_is_ahead_and_nothing_behind(make_env):
    env = make_env(**SENSES, sweep_memory=8)
    observation, _ = env.reset(options={"spec": open_arena()})
    memory = observation["sweep_memory"]
    assert memory.shape == (8, 3) and env.observation_space["sweep_memory"].contains(memory)
    assert memory[AHEAD, NEAR] == 0.0  # the 90-degree fan covers the 45-degree sector ahead, out to the rays' length
    assert memory[BEHIND, NEAR] > 0.9  # behind: only the floor under the body
    assert memory[AHEAD, MIDDLE] > 0.9  # beyond the rays' reach (their length from the eye) nothing is looked over
    assert memory[LEFT, NEAR] > 0.9 and memory[RIGHT, NEAR] > 0.9


def test_the_floor_under_the_body_counts_as_looked_over(make_env):
    env = make_env(**SENSES, sweep_memory=8)
    memory = env.reset(options={"spec": open_arena()})[0]["sweep_memory"]
    assert 0.9 < memory[BEHIND, NEAR] < 1.0  # out of the fan's sight: only the disk of radius 2 round the head


def test_what_was_looked_over_is_kept_and_turned_with_the_body(make_env):
    env = make_env(**SENSES, sweep_memory=8)
    env.reset(options={"spec": open_arena()})
    teleport(env, 0.0, 0.0, math.pi / 2)  # now facing +y: what was ahead is on the right
    memory = env.step(env.body.rest_action())[0]["sweep_memory"]
    assert memory[RIGHT, NEAR] < 0.1 and memory[AHEAD, NEAR] == 0.0
    assert memory[LEFT, NEAR] > 0.9 and memory[BEHIND, NEAR] > 0.9


def test_the_floor_behind_a_wall_stays_unlooked_at(make_env):
    wall = ObjectSpec("wall", "box", (6.0, 0.0, 2.5), (1.0, 20.0, 5.0))
    env = make_env(**SENSES, sweep_memory=8)
    open_floor = env.reset(options={"spec": open_arena()})[0]["sweep_memory"]
    walled = env.reset(options={"spec": open_arena(wall)})[0]["sweep_memory"]
    assert open_floor[AHEAD, NEAR] == 0.0
    assert 0.4 < walled[AHEAD, NEAR] < 0.9  # the rays stop at the wall 5.5 ahead; the floor beyond it is unlooked at


def test_walking_on_reads_the_old_view_behind_and_a_reset_forgets(make_env):
    env = make_env(**SENSES, sweep_memory=8)
    env.reset(options={"spec": open_arena()})
    teleport(env, 15.0, 0.0, 0.0)  # one ray length on, same heading
    memory = env.step(env.body.rest_action())[0]["sweep_memory"]
    assert memory[BEHIND, NEAR] < 0.5  # the fan's first look lies behind now
    assert memory[AHEAD, NEAR] == 0.0
    fresh = env.reset(options={"spec": open_arena()})[0]["sweep_memory"]
    new = make_env(**SENSES, sweep_memory=8).reset(options={"spec": open_arena()})[0]["sweep_memory"]
    np.testing.assert_array_equal(fresh, new)


def test_floor_outside_the_arena_counts_for_nothing(make_env):
    env = make_env(**SENSES, sweep_memory=8)
    observation, _ = env.reset(options={"spec": open_arena(agent=(0.0, 0.0, 0.0))})
    assert observation["sweep_memory"][AHEAD, MIDDLE] > 0.9  # the 50-wide arena reaches 25 ahead
    teleport(env, 24.0, 0.0, 0.0)  # against the arena's edge, facing out
    memory = env.step(env.body.rest_action())[0]["sweep_memory"]
    assert memory[AHEAD, MIDDLE] == 0.0 and memory[AHEAD, FAR] == 0.0  # no floor there at all


def test_without_it_there_is_no_key(make_env):
    observation, _ = make_env(**SENSES).reset(options={"spec": open_arena()})
    assert "sweep_memory" not in observation


@pytest.mark.parametrize("bad", [-1, 37, 2.5, "8", True])
def test_a_bad_count_is_refused_by_name(make_env, bad):
    with pytest.raises(ConfigError, match=r"sensors\.sweep_memory.*allowed: an integer from 0 to 36"):
        make_env(**SENSES, sweep_memory=bad)


def test_it_needs_the_rays(make_env):
    with pytest.raises(ConfigError, match=r"sensors\.sweep_memory.*'sensors\.rays': false"):
        make_env(rays=False, sweep_memory=8)


def test_gymnasiums_checker_passes_with_it(make_env):
    from gymnasium.utils.env_checker import check_env

    check_env(make_env(**SENSES, sweep_memory=8, action_mode="gait"), skip_render_check=True)
