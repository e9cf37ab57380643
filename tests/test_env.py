"""The Gymnasium environment: API, spaces, determinism, rendering."""

import gymnasium as gym
import numpy as np
import pytest
from conftest import open_arena, sphere
from gymnasium.utils.env_checker import check_env

import aaai  # noqa: F401  (registers the ids)
from aaai.config import ConfigError
from aaai.spec.kinds import KIND_INDEX, KINDS


def test_ids_are_registered_per_level():
    assert "aaai/AnimalAI-v0" in gym.registry
    env = gym.make("aaai/L1-FoodRetrieval-v0", difficulty=4)
    _, info = env.reset(seed=1)
    assert (info["level"], info["difficulty"], info["seed"]) == (1, 4, 1)
    env.close()


@pytest.mark.parametrize("level", [0, 1])
def test_passes_gymnasium_env_checker_with_rays_and_camera(level):
    env = gym.make("aaai/AnimalAI-v0", level=level, difficulty=3, rays=True, camera=True, camera_resolution=32)
    check_env(env.unwrapped)
    env.close()


def test_spaces_follow_the_sensor_config(make_env):
    env = make_env(
        rays=True,
        rays_per_side=5,
        camera=True,
        camera_resolution=64,
        camera_grayscale=True,
        joint_velocities=True,
        head_orientation=True,
        foot_contacts=True,
    )
    space = env.observation_space
    assert space["rays"].shape == (11, len(KINDS) + 2)
    assert space["camera"].shape == (64, 64, 1) and space["camera"].dtype == np.uint8
    assert space["joint_velocities"].shape == (8,)
    assert space["head_orientation"].shape == (3,)
    assert space["foot_contacts"].shape == (4,)
    observation, _ = env.reset(seed=0)
    assert space.contains(observation)
    assert observation["head_orientation"] == pytest.approx([0, 0, -1], abs=1e-3)  # upright at rest
    plain = make_env()
    assert set(plain.observation_space.spaces) == {"joints"}


def test_flat_rays_are_the_grid_row_by_row(make_env):
    grid, flat = make_env(rays=True, rays_per_side=3), make_env(rays=True, rays_per_side=3, rays_flat=True)
    assert flat.observation_space["rays"].shape == (7 * (len(KINDS) + 2),)
    for env in (grid, flat):
        env.reset(seed=4, options={"level": 0, "difficulty": 0})
    action = np.full(8, 0.3, np.float32)
    for _ in range(5):
        seen_grid, seen_flat = grid.step(action)[0]["rays"], flat.step(action)[0]["rays"]
    assert flat.observation_space.contains(flat.step(action)[0])
    np.testing.assert_array_equal(seen_flat, seen_grid.reshape(-1))
    assert seen_grid[:, :-1].sum() == 7  # every ray saw exactly one kind (or nothing)


def run_random(env, seed, steps, level):
    observation, _ = env.reset(seed=seed, options={"level": level, "difficulty": 5})
    rng = np.random.default_rng(seed)
    trace = [observation]
    for _ in range(steps):
        observation, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 8).astype(np.float32))
        trace.append((observation, reward, terminated, truncated, info["reward_terms"]))
        if terminated or truncated:
            observation, _ = env.reset()
            trace.append(observation)
    return trace


def assert_identical(a, b):
    """Bit-for-bit equality of nested observations, rewards and flags."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            assert_identical(a[key], b[key])
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_identical(x, y)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    else:
        assert a == b


@pytest.mark.parametrize("level", [0, 1])
def test_same_seed_and_actions_give_the_same_trajectory_bit_for_bit(make_env, level):
    sensors = dict(rays=True, camera=True, camera_resolution=32)
    first = run_random(make_env(**sensors), seed=7, steps=300, level=level)
    second = run_random(make_env(**sensors), seed=7, steps=300, level=level)
    assert_identical(first, second)


def test_reset_to_a_seed_again_after_other_episodes_repeats_it(make_env):
    env = make_env(rays=True, camera=True, camera_resolution=16)
    first = run_random(env, seed=3, steps=150, level=1)
    run_random(env, seed=4, steps=100, level=0)
    run_random(env, seed=5, steps=100, level=1)
    assert_identical(first, run_random(env, seed=3, steps=150, level=1))


def test_reset_options_switch_level_and_difficulty(make_env):
    env = make_env(level=0)
    _, info = env.reset(seed=2, options={"level": "L1", "difficulty": 9})
    assert (info["level"], info["level_name"], info["difficulty"]) == (1, "food_retrieval", 9)
    _, info = env.reset(seed=2)
    assert info["level"] == 1  # the switch lasts until the next switch
    with pytest.raises(ConfigError, match="reset option 'levle' does not exist"):
        env.reset(options={"levle": 0})


def test_unseeded_resets_draw_new_training_seeds(make_env):
    env = make_env()
    env.reset(seed=10)
    seeds = {env.reset()[1]["seed"] for _ in range(5)}
    assert len(seeds) == 5 and all(0 <= s < 1288490240 for s in seeds)


def test_rays_see_the_food_ahead_and_the_wall_behind(make_env):
    env = make_env(rays=True, rays_per_side=2, ray_max_angle=180)
    spec = open_arena(sphere("food_green", 8.0, 0.0, 2.0), agent=(0.0, 0.0, 0.0))
    observation, _ = env.reset(options={"spec": spec})
    rays = observation["rays"]  # angles -180, -90, 0, 90, 180
    forward = rays[2]
    assert forward[KIND_INDEX["food_green"]] == 1
    assert forward[-1] == pytest.approx((8.0 - 1.0 - 1.55) / 15, abs=0.05)
    assert rays[0][len(KINDS)] == 1 and rays[0][-1] == 1.0  # backward: the wall is 25 away, beyond reach
    env_long = make_env(rays=True, rays_per_side=2, ray_max_angle=180, ray_length=30)
    observation, _ = env_long.reset(options={"spec": spec})
    assert observation["rays"][0][KIND_INDEX["wall"]] == 1


def test_camera_sees_green_food_ahead(make_env):
    env = make_env(camera=True, camera_resolution=64)
    observation, _ = env.reset(options={"spec": open_arena(sphere("food_green", 6.0, 0.0, 3.0))})
    image = observation["camera"].astype(int)
    centre = image[24:40, 24:40]
    assert (centre[..., 1] > centre[..., 0] + 60).mean() > 0.5  # mostly green in the middle


def test_rgb_array_render_and_headless_human_mode(make_env, monkeypatch):
    env = make_env(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.std() > 5
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="needs a display.*rgb_array"):
        make_env(render_mode="human")


def test_bad_actions_are_refused(make_env):
    env = make_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action: got shape \(3,\)"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="non-finite"):
        env.step(np.full(8, np.nan))


def test_an_env_pickles_to_its_configuration_and_copies_are_independent():
    import copy
    import pickle
    import subprocess
    import sys

    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(camera=True, camera_resolution=16)
    env.reset(seed=3, options={"level": 2, "difficulty": 4})
    duplicate = copy.deepcopy(env)
    duplicate.close()  # closing a copy leaves the original running
    observation, _ = env.reset(seed=5)
    assert env.step(np.zeros(8))[0]["camera"].shape == (16, 16, 3)
    code = (
        "import pickle, sys, numpy as np\n"
        "env = pickle.loads(sys.stdin.buffer.read())\n"
        "observation, info = env.reset(seed=5)\n"
        "print(env.level, env.difficulty, info['level_name'], observation['camera'].shape)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], input=pickle.dumps(env), capture_output=True)
    assert result.returncode == 0, result.stderr.decode()
    assert result.stdout.decode().split() == ["2", "4", "y_maze", "(16,", "16,", "3)"]
    env.close()


@pytest.mark.parametrize(
    "change, words",
    [
        (dict(agent=(30.0, 0.0, 0.0)), ["not clear"]),
        (dict(arena_size=(float("nan"), 50.0)), ["arena size", "finite"]),
        (dict(tiles=(5, 5), holes=((9, 9),)), ["hole lies outside"]),
    ],
)
def test_a_hand_made_spec_is_checked_before_it_is_run(change, words):
    from dataclasses import replace

    from conftest import open_arena

    from aaai.config import ConfigError
    from aaai.env import AnimalAIEnv
    from aaai.spec import AgentPose

    change = dict(change)  # the parameter itself stays as it was (pytest may run the test again in this process)
    if "agent" in change:
        change["agent"] = AgentPose(*change["agent"])
    spec = replace(open_arena(), **change)
    env = AnimalAIEnv(rays=False)
    try:
        with pytest.raises(ConfigError) as error:
            env.reset(options={"spec": spec})
        assert "not valid" in str(error.value) and all(word in str(error.value) for word in words)
        if "agent" in change:  # an explicit opt-out runs it all the same
            env.reset(options={"spec": spec, "check": False})
            env.step(np.zeros(8))
    finally:
        env.close()


def test_step_before_reset_and_use_after_close_get_clear_errors():
    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(rays=False, render_mode="rgb_array")
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step(np.zeros(8))
    env.reset(seed=1)
    env.close()
    env.close()  # closing twice is harmless
    for call in (lambda: env.step(np.zeros(8)), lambda: env.reset(seed=1), env.render):
        with pytest.raises(gym.error.ClosedEnvironmentError, match="closed"):
            call()


def test_the_grayscale_camera_sees_the_colour_cameras_scene_as_its_luminance(make_env):
    spec = open_arena(sphere("food_green", 6.0, 0.0, 3.0))
    colour, grey = (
        make_env(camera=True, camera_resolution=32),
        make_env(camera=True, camera_resolution=32, camera_grayscale=True),
    )
    rgb = colour.reset(options={"spec": spec})[0]["camera"].astype(float)
    seen = grey.reset(options={"spec": spec})[0]["camera"]
    assert seen.shape == (32, 32, 1) and seen.dtype == np.uint8
    luminance = rgb @ [0.299, 0.587, 0.114]  # ITU-R BT.601, as OpenCV's RGB to grey
    assert np.abs(seen[..., 0] - luminance).max() <= 1.0
    assert seen.std() > 10  # sky, floor and food: not a flat picture
    empty = grey.reset(options={"spec": open_arena()})[0]["camera"]
    centre = (slice(12, 20), slice(12, 20))
    assert np.abs(seen[centre].astype(int) - empty[centre].astype(int)).mean() > 10  # the food in front shows
