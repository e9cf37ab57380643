"""agent.body: sphere, Animal-AI's own body: its spaces, its speeds measured in physics, its
reference controller, and a bad body name (on arena files: test_sphere_arenas.py; the cost of limbs:
test_limbs.py)."""

import dataclasses
import math

import numpy as np
import pytest
from click.testing import CliRunner
from gymnasium.utils.env_checker import check_env

from aaai.agent.sphere import AAI_DRAG, AAI_TOP_SPEED, LEVEL_ARENA, TURN_RATE
from aaai.config import ConfigError
from aaai.env import AnimalAIEnv
from aaai.levels import generate
from aaai.levels.seeds import RESERVED_SEEDS
from aaai.task.reference import ReferenceController
from cli.main import cli

SCALE = LEVEL_ARENA / 40.0


@pytest.fixture(scope="module")
def env():
    environment = AnimalAIEnv(level=0, body="sphere", decision_interval=0.02)
    yield environment
    environment.close()


def _open_floor(env):
    """L0's floor made 200 across, with nothing on it: room to reach top speed."""
    spec = generate(0, 0, 1)
    spec = dataclasses.replace(spec, objects=(), arena_size=(200.0, 200.0))
    env.reset(seed=1, options={"spec": spec, "check": False})


def _yaw(env) -> float:
    rotation = env.unwrapped.body.head_pose()[1]
    return math.atan2(rotation[1, 0], rotation[0, 0])


def test_the_sphere_passes_gymnasiums_checker_with_every_sense():
    env = AnimalAIEnv(
        level=0,
        body="sphere",
        camera=True,
        camera_resolution=8,
        joint_velocities=True,
        head_orientation=True,
        foot_contacts=True,
    )
    try:
        with pytest.warns(UserWarning):  # joint_velocities is unbounded, as the quadruped's
            check_env(env, skip_render_check=True)
        assert env.action_space.shape == (3,)  # forward, turn, crouch: the gait mode's commands
        assert env.observation_space["joints"].shape == (2,)  # forward speed, turn rate
    finally:
        env.close()


@pytest.mark.parametrize("forward", [1.0, -1.0])
def test_forward_reaches_animal_ais_top_speed_scaled_to_the_arena(env, forward):
    _open_floor(env)
    start = env.unwrapped.body.head_pose()[0]
    seconds = 3.0
    for _ in range(round(seconds / 0.02) - 10):
        env.step(np.array([forward, 0.0, 0.0], np.float32))
    before = env.unwrapped.body.head_pose()[0]
    for _ in range(10):
        observation, _, _, _, info = env.step(np.array([forward, 0.0, 0.0], np.float32))
    after = env.unwrapped.body.head_pose()[0]
    speed = (after[1] - before[1]) / 0.2  # it starts facing north (+y)
    top = AAI_TOP_SPEED * SCALE  # 26.25 units/s
    expected = forward * top * (1 - math.exp(-AAI_DRAG * (seconds - 0.1)))  # the drag's rise, mid-window
    assert speed == pytest.approx(expected, rel=0.02)
    assert abs(after[0] - start[0]) < 1e-6  # straight along its heading
    assert observation["joints"][0] == pytest.approx(forward * (1 - math.exp(-AAI_DRAG * seconds)), abs=0.02)
    assert info["reward_terms"]["ground"] == 0.0  # it rests on its head: no ground penalty


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_turning_turns_it_at_animal_ais_rate_on_the_spot(env, turn):
    _open_floor(env)
    start = env.unwrapped.body.head_pose()[0]
    turned = 0.0
    for _ in range(50):  # 1 s
        before = _yaw(env)
        observation, *_ = env.step(np.array([0.0, turn, 0.0], np.float32))
        turned += (_yaw(env) - before + math.pi) % (2 * math.pi) - math.pi
    assert math.degrees(turned) == pytest.approx(turn * math.degrees(TURN_RATE), abs=0.5)  # 100 degrees/s
    assert np.linalg.norm(env.unwrapped.body.head_pose()[0][:2] - start[:2]) < 1e-3
    assert observation["joints"][1] == pytest.approx(turn)


def test_the_reference_steers_the_sphere_to_the_food_on_l0():
    env = AnimalAIEnv(level=0, difficulty=10, body="sphere")
    try:
        controller = ReferenceController(env)
        seed = RESERVED_SEEDS.start
        observation, _ = env.reset(seed=seed)
        controller.reset(seed)
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, info = env.step(controller(observation))
            total, done = total + reward, terminated or truncated
        assert terminated and info["food_eaten"] == 1
        assert total >= info["max_reward"]
        assert info["steps"] < 250  # 5 s of the 25 allowed: it goes at the sphere's speed
    finally:
        env.close()


def test_a_bad_body_name_gets_one_clear_message(tmp_path):
    with pytest.raises(ConfigError) as caught:
        AnimalAIEnv(body="blob")
    for part in ("agent.body", "'blob'", "quadruped, quadruped16, sphere"):
        assert part in str(caught.value)
    config = tmp_path / "blob.yaml"
    config.write_text("agent:\n  body: blob\n")
    result = CliRunner().invoke(cli, ["run", "--config", str(config), "--levels", "0", "--episodes", "1"])
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert "agent.body" in result.output and "'blob'" in result.output and "sphere" in result.output


def test_the_viewer_draws_the_sphere_as_a_disc_of_its_size(env):
    from aaai.tools.viewer import live_agent

    _open_floor(env)
    agent = live_agent(env.unwrapped.snapshot())
    assert agent.legs == () and agent.radius == pytest.approx(0.625)
