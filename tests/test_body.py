"""The body, tested by running physics."""

import math

import numpy as np
import pytest
from conftest import heading, open_arena

from aaai.sim.gait import SineGait


@pytest.mark.parametrize("body, n_axes", [("quadruped", 8), ("quadruped16", 16)])
def test_every_axis_is_driven_and_only_that_one_moves(make_env, body, n_axes):
    env = make_env(body=body)
    assert env.action_space.shape == (n_axes,)
    assert env.observation_space["joints"].shape == (n_axes,)
    for axis in range(n_axes):
        observation, _ = env.reset(seed=0, options={"spec": open_arena()})
        rest = observation["joints"].copy()
        action = np.zeros(n_axes, np.float32)
        action[axis] = 0.6
        for _ in range(40):
            observation, *_ = env.step(action)
        moved = np.abs(observation["joints"] - rest)
        assert moved[axis] > 0.4, f"axis {env.body.joint_names[axis]} did not follow its action"
        others = np.delete(moved, axis)
        assert others.max() < 0.05, f"driving {env.body.joint_names[axis]} moved other axes: {others}"


def test_velocity_mode_drives_each_axis(make_env):
    env = make_env(action_mode="velocity")
    for axis in range(8):
        observation, _ = env.reset(seed=0, options={"spec": open_arena()})
        action = np.zeros(8, np.float32)
        action[axis] = -0.3
        for _ in range(5):
            observation, *_ = env.step(action)
        assert observation["joints"][axis] < -0.1
        assert np.abs(np.delete(observation["joints"], axis)).max() < 0.05


def walk(env, direction, seconds=10.0):
    observation, _ = env.reset(seed=0, options={"spec": open_arena(agent=(0.0, 0.0, 0.7))})
    gait = SineGait.for_env(env, direction)
    start, rotation = env.body.head_pose()
    yaws, lowest_up = [heading(rotation)], 1.0
    for _ in range(round(seconds / env.control_dt)):
        observation, _, terminated, truncated, _ = env.step(gait(observation))
        assert not (terminated or truncated)
        position, rotation = env.body.head_pose()
        yaws.append(heading(rotation))
        lowest_up = min(lowest_up, rotation[2, 2])
    facing = np.array([math.cos(yaws[0]), math.sin(yaws[0])])
    travelled = float((position - start)[:2] @ facing)
    turned = math.degrees(np.unwrap(yaws)[-1] - yaws[0])
    return travelled, turned, lowest_up


@pytest.mark.parametrize("body", ["quadruped", "quadruped16"])
def test_gait_walks_forward_and_backward_without_flipping(make_env, body):
    env = make_env(body=body)
    forward, _, up = walk(env, "forward")
    assert forward >= 5.0 and up > 0.5
    backward, _, up = walk(env, "backward")
    assert backward <= -5.0 and up > 0.5


@pytest.mark.parametrize("direction, sign", [("left", 1), ("right", -1)])
def test_gait_turns_at_least_90_degrees_in_10_seconds(make_env, direction, sign):
    env = make_env()
    _, turned, up = walk(env, direction)
    assert sign * turned >= 90 and up > 0.5


def test_body_stands_up_off_its_head(make_env):
    env = make_env()
    observation, _ = env.reset(seed=0, options={"spec": open_arena()})
    gait = SineGait.for_env(env, "forward")
    for _ in range(100):
        observation, _, _, _, info = env.step(gait(observation))
    head, _ = env.body.head_pose()
    assert head[2] > 1.8 and info["reward_terms"]["ground"] == 0.0


def test_shipped_urdf_files_are_what_the_writer_writes():
    from aaai.agent.urdf_writer import URDF_DIR, all_files

    for name, text in all_files().items():
        assert (URDF_DIR / name).read_text() == text, f"{name} is stale: run python -m aaai.agent.urdf_writer"


def test_the_physics_only_body_behaves_like_the_drawn_one(make_env):
    drawn, plain = make_env(camera=True, camera_resolution=8), make_env()
    assert drawn.visuals and not plain.visuals
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (100, 8))
    trajectories = []
    for env in (drawn, plain):
        observation, _ = env.reset(seed=3)
        joints = [env.step(action)[0]["joints"] for action in actions]
        trajectories.append(np.array(joints))
    assert np.array_equal(trajectories[0], trajectories[1])
