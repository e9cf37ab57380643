"""The steerable gait, tested by running physics: speed, turning, blending, crouching."""

import math

import numpy as np
import pytest
from conftest import heading, open_arena

from aaai.sim.gait import SineGait, approach, load_parameters, steer

OPEN = 200.0  # an arena this big: 10 s of walking never reaches a wall


def walk(env, forward, turn, seconds=10.0, crouch=0.0):
    """Fixed commands from the centre of a big empty arena: (distance along the start heading,
    degrees turned (anticlockwise +), lowest head height, highest share of steps with the head on
    the floor)."""
    env.reset(options={"spec": open_arena(arena_size=(OPEN, OPEN))})
    gait = SineGait.for_env(env)
    gait.command(forward, turn, crouch)
    start, rotation = env.body.head_pose()
    yaws, heights, ground = [heading(rotation)], [], 0
    steps = round(seconds / env.control_dt)
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(gait())
        assert not (terminated or truncated)
        position, rotation = env.body.head_pose()
        yaws.append(heading(rotation))
        heights.append(position[2])
        ground += info["reward_terms"]["ground"] != 0
    facing = np.array([math.cos(yaws[0]), math.sin(yaws[0])])
    return (
        float((position - start)[:2] @ facing),
        math.degrees(np.unwrap(yaws)[-1] - yaws[0]),
        float(np.mean(heights[len(heights) // 2 :])),
        ground / steps,
    )


def test_the_gait_walks_3_units_a_second_with_the_head_off_the_floor(make_env):
    env = make_env(max_steps=10000)
    travelled, _, _, on_floor = walk(env, 1.0, 0.0)
    assert travelled >= 20.0 and on_floor == 0.0  # 10 s, open loop: the start heading drifts a little


def test_the_gait_walks_backward(make_env):
    travelled, _, _, _ = walk(make_env(max_steps=10000), -1.0, 0.0)
    assert travelled <= -15.0


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_the_turn_command_turns_the_body_its_way(make_env, turn):
    _, turned, _, _ = walk(make_env(max_steps=10000), 0.0, turn)
    assert turn * turned >= 360.0  # a full turn within 10 s, the way it is asked


def test_crouching_lowers_the_head(make_env):
    env = make_env(max_steps=10000)
    _, _, standing, _ = walk(env, 0.0, 0.0, seconds=3.0)
    _, _, crouching, _ = walk(env, 0.0, 0.0, seconds=3.0, crouch=1.0)
    assert crouching < standing - 0.2


def test_a_new_command_is_blended_in_without_a_jerk(make_env):
    env = make_env()
    env.reset(options={"spec": open_arena()})
    gait = SineGait.for_env(env)
    before = np.array([gait() for _ in range(100)])
    gait.command(-1.0, 1.0)  # full forward to full backward and turning, at once
    switching = np.array([before[-1]] + [gait() for _ in range(50)])
    after = np.array([gait() for _ in range(100)])
    steadiest = max(np.abs(np.diff(before, axis=0)).max(), np.abs(np.diff(after, axis=0)).max())
    assert np.abs(np.diff(switching, axis=0)).max() <= steadiest + 0.05  # no step harder than walking itself
    assert not np.allclose(after[-25:], before[-25:])  # ... and the new command does take effect


def test_the_gait_drives_only_its_axes_and_stays_in_range(make_env):
    for body in ("quadruped", "quadruped16"):
        env = make_env(body=body)
        gait = SineGait.for_env(env)
        gait.command(0.7, -0.4, 0.5)
        actions = np.array([gait() for _ in range(200)])
        assert actions.shape == (200, env.action_space.shape[0])
        assert (np.abs(actions) <= 1.0).all()
        moving = np.abs(actions).max(axis=0) > 0
        names = env.body.joint_names
        assert all(
            moving[i] == (n.endswith(("hip", "hip_updown", "knee", "knee_sideways"))) for i, n in enumerate(names)
        )


@pytest.mark.parametrize(
    "error, forward_sign, turn_sign", [(0.5, 1, 1), (-0.5, 1, -1), (0.0, 1, 0), (2.8, -1, -1), (-2.8, -1, 1)]
)
def test_steer_turns_toward_the_point_and_backs_up_to_a_near_one_behind(error, forward_sign, turn_sign):
    forward, turn = steer(error, 2.0)
    assert np.sign(forward) == forward_sign and np.sign(turn) == turn_sign


def test_steer_walks_forward_round_to_a_far_point_behind():
    forward, turn = steer(2.8, 20.0)
    assert forward == 0.0 and turn == 1.0  # turns on the spot instead of reversing a long way


def test_approach_crouches_only_near_the_food():
    parameters = load_parameters()
    assert approach(parameters, 0.0, 20.0, 1.0)[2] == 0.0
    assert approach(parameters, 0.0, 1.0 + parameters.crouch_distance / 2, 1.0)[2] == 1.0


@pytest.mark.parametrize(
    "text, words",
    [
        ("frequency: 2\nstride: 1\n", ["'stride'", "does not exist", "frequency"]),
        ("frequency: fast\n", ["'frequency'", "'fast'", "a finite number"]),
    ],
)
def test_a_bad_gait_file_fails_with_one_clear_message(tmp_path, text, words):
    from aaai.config import ConfigError

    path = tmp_path / "gait.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as error:
        load_parameters(path)
    assert all(word in str(error.value) for word in words)


@pytest.mark.long
def test_the_tuner_writes_parameters_the_gait_loads(tmp_path):
    from aaai.tools.gait_tuning import main

    path = tmp_path / "gait.yaml"
    assert main(["--evaluations", "12", "--write", str(path)]) == 0
    tuned = load_parameters(path)
    assert tuned != load_parameters() and 0.5 <= tuned.frequency <= 4.0
