"""Discrete mode: Animal-AI's actions (forward/backward, right/left) and a crouch, each the gait's
command at full strength, and a student that learns them as choices."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from click.testing import CliRunner
from gymnasium.utils.env_checker import check_env

import aaai  # noqa: F401 - registers the ids
from aaai.env import AnimalAIEnv
from aaai.sim.gait import CHOICE_THRESHOLD, choice_of_command
from tests.test_gait_mode import open_floor, pose

# Animal-AI's coding, written out here so that a swapped direction in the environment shows.
FORWARD = {0: 0.0, 1: 1.0, 2: -1.0}  # none, forward, backward
TURN = {0: 0.0, 1: -1.0, 2: 1.0}  # none, right, left (the gait's turn: + is left)


@pytest.mark.parametrize("body", ["quadruped", "sphere"])
def test_discrete_mode_passes_gymnasiums_checker(body):
    env = gym.make("aaai/AnimalAI-v0", action_mode="discrete", body=body, disable_env_checker=True)
    try:
        assert env.action_space == gym.spaces.MultiDiscrete([3, 3, 2])
        check_env(env.unwrapped, skip_render_check=True)
    finally:
        env.close()


def test_a_choice_is_the_gait_command_it_stands_for_bit_for_bit():
    chosen = AnimalAIEnv(level=1, difficulty=3, action_mode="discrete")
    commanded = AnimalAIEnv(level=1, difficulty=3, action_mode="gait")
    try:
        chosen.reset(seed=11)
        commanded.reset(seed=11)
        rng = np.random.default_rng(0)
        for _ in range(40):
            choice = rng.integers([0, 0, 0], [3, 3, 2])
            command = np.array([FORWARD[choice[0]], TURN[choice[1]], float(choice[2])])
            mine, reward, terminated, truncated, info = chosen.step(choice)
            theirs, reward2, *_, info2 = commanded.step(command)
            assert reward == reward2 and info["reward_terms"] == info2["reward_terms"]
            assert all(np.array_equal(mine[key], theirs[key]) for key in mine)
            if terminated or truncated:
                break
    finally:
        chosen.close()
        commanded.close()


def test_turn_choice_2_turns_left_and_1_right():
    env = AnimalAIEnv(level=0, difficulty=0, action_mode="discrete", max_steps=2000)
    try:
        for choice, sign in ((2, 1), (1, -1)):
            env.reset(seed=5, options={"spec": open_floor(env)})
            _, yaw = pose(env)
            for _ in range(20):
                env.step(np.array([0, choice, 0]))
            _, yaw_end = pose(env)
            assert sign * math.remainder(yaw_end - yaw, 2 * math.pi) > math.radians(45), choice
    finally:
        env.close()


@pytest.mark.parametrize(
    "action", [[3, 0, 0], [0, 0, 2], [-1, 0, 0], [1.5, 0, 0], [np.nan, 0, 0], [1, 0], [1, 0, 0, 0]]
)
def test_a_wrong_choice_is_refused_naming_the_choices(action):
    env = AnimalAIEnv(action_mode="discrete")
    try:
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"action: got .*allowed in action_mode discrete: 3 whole numbers"):
            env.step(np.array(action))
    finally:
        env.close()


def test_a_command_is_labelled_with_the_nearest_choice_a_hair_either_side_of_the_threshold():
    hair = 1e-6
    assert choice_of_command([CHOICE_THRESHOLD - hair, -(CHOICE_THRESHOLD - hair), 0.5 - hair]).tolist() == [0, 0, 0]
    assert choice_of_command([CHOICE_THRESHOLD + hair, CHOICE_THRESHOLD + hair, 0.5]).tolist() == [1, 2, 1]
    assert choice_of_command([-(CHOICE_THRESHOLD + hair), -(CHOICE_THRESHOLD + hair), 1.0]).tolist() == [2, 1, 1]
    assert choice_of_command([0.5, -1.0, 0.0]).tolist() == [1, 1, 0]  # the reference's slow approach: forward


def test_the_reference_and_the_built_in_policies_act_in_discrete_mode():
    from aaai.scoring.episodes import play
    from aaai.scoring.policies import resolve

    env = AnimalAIEnv(level=1, difficulty=3, action_mode="discrete")
    try:
        result = play(env, resolve("reference").build(env), seed=5)
        assert result.info["food_eaten"] >= 1 and result.terminated  # it eats its way to the end
        for name in ("random", "gait"):
            action = resolve(name).build(env)(env.reset(seed=1)[0])
            assert env.action_space.contains(np.asarray(action, np.int64)), name
    finally:
        env.close()


def test_a_discrete_student_learns_the_teachers_choice_where_a_regression_stands_still():
    """Where the same observation is labelled a left turn 60 times and a right turn 40, the student
    of choices turns left; the student of gait commands, fitted on the same labels, learns their
    mean (a turn of 0.2) and all but stands."""
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    from aaai.train.student import build_policy, fit

    observation_space = gym.spaces.Dict({"rays": gym.spaces.Box(0.0, 1.0, (4,), np.float32)})
    observations = {"rays": np.full((100, 4), 0.5, np.float32)}
    left = np.arange(100) < 60
    choices = np.where(left[:, None], [1, 2, 0], [1, 1, 0]).astype(np.float32)
    commands = np.where(left[:, None], [1.0, 1.0, 0.0], [1.0, -1.0, 0.0]).astype(np.float32)
    chooser = build_policy(observation_space, gym.spaces.MultiDiscrete([3, 3, 2]), 16)
    fit(chooser, observations, choices, epochs=60, seed=0)
    regressor = build_policy(
        observation_space, gym.spaces.Box(np.array([-1, -1, 0], np.float32), np.float32(1), (3,), np.float32), 16
    )
    fit(regressor, observations, commands, epochs=60, seed=0)
    one = {"rays": observations["rays"][0]}
    assert chooser.predict(one, deterministic=True)[0].tolist() == [1, 2, 0]  # forward, turning left
    assert abs(float(regressor.predict(one, deterministic=True)[0][1])) < 0.3  # the mean of the two turns


def test_a_discrete_student_run_is_scored_without_trust_and_refused_by_a_gait_env(tmp_path):
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    from aaai.config import load_config
    from aaai.scoring.policies import resolve
    from aaai.train.student import train_student
    from aaai_cli.main import cli
    from tests.test_student import TINY

    run = tmp_path / "student"
    train_student(run, load_config(TINY, action_mode="discrete", dagger_iterations=1), say=lambda message: None)
    out = tmp_path / "scores.csv"
    scored = CliRunner().invoke(
        cli, ["eval", "--policy", str(run), "--levels", "0", "--difficulty", "0", "-k", "1", "--out", str(out)]
    )
    assert scored.exit_code == 0, scored.output
    assert len(out.read_text().splitlines()) == 2
    env = AnimalAIEnv(level=0, action_mode="gait")
    try:
        model = run / "final" / "model.zip"
        with pytest.raises(Exception, match="action"):
            resolve(str(model)).build(env)
    finally:
        env.close()


def test_an_rllib_policy_in_discrete_mode_takes_each_parts_likeliest_choice():
    """RLlib's module gives the logits of each part in turn (3, 3 and 2 of them); the scored action
    is each part's likeliest choice, in the environment's space."""
    pytest.importorskip("ray.rllib", reason="needs the ray extra")
    import torch

    from aaai.scoring.policies import OnGrid
    from aaai.scoring.rllib_policy import RLlibPolicy

    class Module:
        def forward_inference(self, batch):
            return {"action_dist_inputs": torch.tensor([[0.0, 5.0, 1.0, 2.0, 0.0, 9.0, 3.0, 1.0]])}

    env = AnimalAIEnv(action_mode="discrete")
    try:
        policy = RLlibPolicy.__new__(RLlibPolicy)  # its module given here: no checkpoint needed
        policy.torch, policy.module, policy.dtype = torch, Module(), np.float64
        policy.space = env.action_space
        from ray.rllib.utils.spaces.space_utils import get_base_struct_from_space

        policy.structure = get_base_struct_from_space(env.observation_space)
        observation, _ = env.reset(seed=0)
        action = OnGrid(policy)(observation)  # as the scoreboard plays it
        assert action.tolist() == [1, 2, 0]  # forward, left, standing
        env.step(action)  # the environment takes it
    finally:
        env.close()


def test_a_recurrent_student_of_choices_is_trained_saved_as_recurrent_ppo_and_scored_by_choices(tmp_path):
    """train.student_policy lstm with agent.action_mode discrete: a RecurrentPPO model over the
    environment's MultiDiscrete space, whose actions are choices the environment takes, and which
    eval scores (its memory through an episode: test_determinism's rows of the committed one)."""
    pytest.importorskip("sb3_contrib", reason="needs the train extra")
    from aaai.config import load_config
    from aaai.scoring.model_archive import read_archive
    from aaai.scoring.model_io import policy_class_name
    from aaai.scoring.policies import resolve
    from aaai.train.student import train_student
    from aaai_cli.main import cli
    from tests.test_student import TINY

    run = tmp_path / "student"
    config = load_config(
        TINY, action_mode="discrete", student_policy="lstm", dagger_iterations=1, dagger_episode_cap=40, net_width=16
    )
    train_student(run, config, say=lambda message: None)
    model = run / "final" / "model.zip"
    assert policy_class_name(read_archive(model)) == "RecurrentMultiInputActorCriticPolicy"
    source = resolve(str(run))
    env = AnimalAIEnv(config=source.play_config())
    try:
        policy = source.build(env)
        observation, _ = env.reset(seed=0)
        action = np.asarray(policy(observation))
        assert env.action_space.contains(action.astype(np.int64)), action
    finally:
        env.close()
    out = tmp_path / "scores.csv"
    scored = CliRunner().invoke(
        cli, ["eval", "--policy", str(run), "--levels", "0", "--difficulty", "0", "-k", "1", "--out", str(out)]
    )
    assert scored.exit_code == 0, scored.output
    assert len(out.read_text().splitlines()) == 2
