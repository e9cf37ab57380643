"""`sensors.sweep_map`: where the rays have looked and what they met, as a map turned with the head;
by running physics: look, teleport or turn the body, then assert.

With ``sweep_map: 10`` the map reaches 30 units (2 ray lengths) each way in blocks 6 across: along
the first axis (behind to ahead) block 5 is 0 to 6 units ahead, 6 is 6 to 12 ahead, 3 is 12 to 6
behind; along the second (right to left) block 4 is 0 to 6 to the right, 5 is 0 to 6 to the left."""

import math

import numpy as np
import pytest
from conftest import open_arena
from test_sweep_memory import SENSES, teleport

from aaai.config import ConfigError
from aaai.spec import ObjectSpec

UNLOOKED, MET = 0, 1
NEAR_AHEAD, FAR_AHEAD, BEHIND = 5, 6, 3
RIGHT, LEFT, FAR_RIGHT = 4, 5, 3


def test_the_map_shows_the_fan_ahead_looked_over_and_the_floor_behind_not(make_env):
    env = make_env(**SENSES, sweep_map=10)
    observation, _ = env.reset(options={"spec": open_arena()})
    view = observation["sweep_map"]
    assert view.shape == (2, 10, 10) and env.observation_space["sweep_map"].contains(view)
    assert "sweep_memory" not in observation  # the map alone, without the sectors
    for side in (RIGHT, LEFT):
        assert view[UNLOOKED, FAR_AHEAD, side] < 0.1  # 6 to 12 ahead, within 45 degrees: in the fan
        assert view[UNLOOKED, BEHIND, side] > 0.9
    assert not view[MET].any()  # nothing within the rays' reach in the open arena


def test_floor_outside_the_arena_reads_nothing(make_env):
    env = make_env(**SENSES, sweep_map=10)
    env.reset(options={"spec": open_arena()})
    teleport(env, 24.0, 0.0, 0.0)  # against the arena's edge (25), facing out
    view = env.step(env.body.rest_action())[0]["sweep_map"]
    assert not view[UNLOOKED, FAR_AHEAD:].any()  # no floor 6 or more ahead
    assert view[UNLOOKED, NEAR_AHEAD - 1, LEFT + 2] > 0.9  # 6 to 0 behind, 12 to 18 to the left: not looked over
    assert view[UNLOOKED, BEHIND - 1, RIGHT] < 0.1  # 18 to 12 behind (x 6 to 12): looked over from the start


def test_a_wall_ahead_is_met_and_the_floor_behind_it_stays_unlooked_at(make_env):
    wall = ObjectSpec("wall", "box", (6.0, 0.0, 2.5), (1.0, 20.0, 5.0))
    env = make_env(**SENSES, sweep_map=10)
    view = env.reset(options={"spec": open_arena(wall)})[0]["sweep_map"]
    assert view[MET, NEAR_AHEAD, RIGHT] == 1.0 and view[MET, NEAR_AHEAD, LEFT] == 1.0  # its face 5.5 ahead
    assert view[MET].sum() <= 6  # nowhere else
    assert view[UNLOOKED, FAR_AHEAD, RIGHT] > 0.9  # beyond the wall


def test_the_map_turns_with_the_body_and_a_reset_forgets(make_env):
    env = make_env(**SENSES, sweep_map=10)
    env.reset(options={"spec": open_arena()})
    teleport(env, 0.0, 0.0, math.pi / 2)  # now facing +y: what was 6 to 12 ahead is 6 to 12 to the right
    view = env.step(env.body.rest_action())[0]["sweep_map"]
    assert view[UNLOOKED, BEHIND + 1, FAR_RIGHT] < 0.1  # 6 to 0 behind, 12 to 6 to the right: looked over before
    assert view[UNLOOKED, BEHIND, LEFT] > 0.9
    fresh = env.reset(options={"spec": open_arena()})[0]["sweep_map"]
    new = make_env(**SENSES, sweep_map=10).reset(options={"spec": open_arena()})[0]["sweep_map"]
    np.testing.assert_array_equal(fresh, new)


def test_with_the_sectors_both_read_the_same_marks(make_env):
    both = make_env(**SENSES, sweep_map=10, sweep_memory=8).reset(options={"spec": open_arena()})[0]
    alone = make_env(**SENSES, sweep_memory=8).reset(options={"spec": open_arena()})[0]
    np.testing.assert_array_equal(both["sweep_memory"], alone["sweep_memory"])
    assert both["sweep_map"].shape == (2, 10, 10)


@pytest.mark.parametrize("bad", [-1, 33, 2.5, "8", True])
def test_a_bad_size_is_refused_by_name(make_env, bad):
    with pytest.raises(ConfigError, match=r"sensors\.sweep_map.*allowed: an integer from 0 to 32"):
        make_env(**SENSES, sweep_map=bad)


def test_it_needs_the_rays(make_env):
    with pytest.raises(ConfigError, match=r"sensors\.sweep_map.*'sensors\.rays': false"):
        make_env(rays=False, sweep_map=8)


def test_gymnasiums_checker_passes_with_it(make_env):
    from gymnasium.utils.env_checker import check_env

    check_env(make_env(**SENSES, sweep_map=8, action_mode="discrete"), skip_render_check=True)
