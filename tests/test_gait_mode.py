"""Gait mode: the action is the gait's (forward, turn, crouch), held for agent.decision_interval."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pybullet as p
import pytest
from gymnasium.utils.env_checker import check_env

import aaai  # noqa: F401 - registers the ids
from aaai.config import ConfigError
from aaai.env import AnimalAIEnv
from aaai.levels import get_level, level_ids
from aaai.registration import level_env_id
from aaai.sim.gait import SineGait

IDS = ["aaai/AnimalAI-v0"] + [level_env_id(get_level(level)) for level in level_ids()]


def pose(env):
    base = env.unwrapped
    position, orientation = p.getBasePositionAndOrientation(base.body.id, physicsClientId=base.client)
    return np.array(position), p.getEulerFromQuaternion(orientation)[2]


@pytest.mark.parametrize("env_id", IDS)
def test_every_id_passes_gymnasiums_checker_in_gait_mode(env_id):
    env = gym.make(env_id, action_mode="gait", disable_env_checker=True)
    try:
        assert env.action_space == gym.spaces.Box(np.array([-1, -1, 0], np.float32), np.float32(1), (3,), np.float32)
        check_env(env.unwrapped, skip_render_check=True)
    finally:
        env.close()


def test_a_gait_action_is_the_gait_run_for_the_held_control_steps_bit_for_bit():
    """One gait-mode step = 5 rotation-mode steps of SineGait with the same command; reward and
    reward terms are summed over them."""
    held = AnimalAIEnv(level=1, difficulty=3, action_mode="gait")
    joints = AnimalAIEnv(level=1, difficulty=3)
    gait = SineGait(joints.body.joint_names, control_dt=joints.control_dt)
    try:
        observation, _ = held.reset(seed=11)
        joint_observation, _ = joints.reset(seed=11)
        gait.reset()
        gait.forward = gait.turn = 0.0
        rng = np.random.default_rng(0)
        for _ in range(30):
            command = rng.uniform([-1, -1, 0], [1, 1, 1])
            observation, reward, terminated, truncated, info = held.step(command)
            gait.command(*command)
            total, terms = 0.0, {}
            for _ in range(5):
                joint_observation, r, term2, trunc2, info2 = joints.step(gait())
                total += r
                for key, value in info2["reward_terms"].items():
                    terms[key] = terms.get(key, 0.0) + value
            assert reward == total
            assert info["reward_terms"] == terms
            assert info["steps"] == info2["steps"]
            for key in observation:
                assert np.array_equal(observation[key], joint_observation[key]), key
            if terminated or truncated:
                break
    finally:
        held.close()
        joints.close()


def test_the_commands_walk_turn_and_crouch_the_way_they_say():
    env = AnimalAIEnv(level=0, difficulty=0, action_mode="gait", max_steps=2000)
    try:

        def run(command, seconds):
            env.reset(seed=5, options={"spec": open_floor(env)})
            start, yaw = pose(env)
            for _ in range(round(seconds / 0.1)):
                env.step(np.array(command))
            end, yaw_end = pose(env)
            return start, yaw, end, yaw_end

        start, yaw, end, _ = run([1, 0, 0], 3.0)
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        assert (end - start)[:2] @ heading > 4.0  # forward: over 4 units along the heading in 3 s
        start, yaw, end, _ = run([-1, 0, 0], 3.0)
        assert (end - start)[:2] @ heading < -3.0  # backward
        _, yaw, _, yaw_end = run([0, 1, 0], 2.0)
        assert math.remainder(yaw_end - yaw, 2 * math.pi) > math.radians(45)  # +turn: to the left
        _, yaw, _, yaw_end = run([0, -1, 0], 2.0)
        assert math.remainder(yaw_end - yaw, 2 * math.pi) < -math.radians(45)
        heights = {}
        for crouch in (0.0, 1.0):
            env.reset(seed=5, options={"spec": open_floor(env)})
            samples = []
            for _ in range(30):
                env.step(np.array([0.0, 0.0, crouch]))
                samples.append(pose(env)[0][2])
            heights[crouch] = np.mean(samples[10:])
        assert heights[1.0] < heights[0.0] - 0.1  # crouching lowers the head
    finally:
        env.close()


def open_floor(env):
    """L0's arena with its food moved far out of the way, so that nothing stops the body."""
    from dataclasses import replace

    from aaai.levels import generate

    spec = generate(0, 0, 5)
    corner = (spec.arena_size[0] / 2 - 4, spec.arena_size[1] / 2 - 4)
    objects = tuple(
        replace(o, position=(*corner, o.position[2])) if o.kind.endswith("food") else o for o in spec.objects
    )
    return replace(spec, objects=objects, agent=replace(spec.agent, x=-corner[0] / 2, y=-corner[1] / 2, yaw=0.0))


def test_the_same_seed_and_commands_give_the_same_trajectory():
    def trajectory():
        env = AnimalAIEnv(level=8, difficulty=6, action_mode="gait")
        try:
            env.reset(seed=3)
            rng = np.random.default_rng(1)
            out = []
            for _ in range(40):
                observation, reward, *_ = env.step(rng.uniform([-1, -1, 0], [1, 1, 1]))
                out.append((observation["rays"].tobytes(), reward))
            return out
        finally:
            env.close()

    assert trajectory() == trajectory()


@pytest.mark.parametrize("interval", [0, -0.1, float("nan"), float("inf"), 0.03, "fast", True])
def test_a_wrong_decision_interval_is_refused_by_name(interval):
    with pytest.raises(ConfigError, match="decision_interval"):
        AnimalAIEnv(action_mode="gait", decision_interval=interval)


def test_a_decision_interval_longer_than_the_episode_is_refused_at_reset():
    env = AnimalAIEnv(action_mode="gait", decision_interval=2.0, max_steps=50)  # 100 control steps > 50
    try:
        with pytest.raises(ConfigError, match="decision_interval.*longer than this episode"):
            env.reset(seed=0)
    finally:
        env.close()
    env = AnimalAIEnv(action_mode="gait", decision_interval=1.0, max_steps=50)  # exactly the episode: allowed
    try:
        env.reset(seed=0)
        *_, truncated, info = env.step(np.array([0.0, 0.0, 0.0]))
        assert truncated and info["steps"] == 50
    finally:
        env.close()


@pytest.mark.parametrize("action", [np.zeros(8), np.zeros(2), np.array([np.nan, 0, 0]), np.array([0, np.inf, 0])])
def test_bad_gait_actions_are_refused(action):
    env = AnimalAIEnv(action_mode="gait")
    try:
        env.reset(seed=0)
        with pytest.raises(ValueError, match="action"):
            env.step(action)
    finally:
        env.close()


def test_out_of_range_commands_are_clipped_to_the_box():
    env = AnimalAIEnv(action_mode="gait")
    try:
        env.reset(seed=0)
        env.step(np.array([5.0, -5.0, -2.0]))
        assert env.gait.target == (1.0, -1.0, 0.0)
    finally:
        env.close()


def test_every_built_in_policy_acts_in_gait_mode():
    from aaai.scoring.episodes import play
    from aaai.scoring.policies import resolve

    env = AnimalAIEnv(level=0, difficulty=0, action_mode="gait", max_steps=100)
    try:
        for name in ("random", "gait", "reference"):
            policy = resolve(name).build(env)
            result = play(env, policy, seed=3)
            assert result.info["steps"] == 100 or result.terminated, name
        start, yaw = None, None
        env.reset(seed=5, options={"spec": open_floor(env)})
        start, yaw = pose(env)
        walker = resolve("gait").build(env)
        for _ in range(20):
            env.step(walker(None))
        end, _ = pose(env)
        assert (end - start)[:2] @ np.array([math.cos(yaw), math.sin(yaw)]) > 2.0  # "gait" walks straight ahead
    finally:
        env.close()
