import time

import pytest

from aaai.agent.body import urdf_path
from aaai.config import ConfigError, config_dir, load_config
from aaai.env import AnimalAIEnv
from aaai.levels import generate
from aaai.levels.params import LevelParamError, resolve, resolve_value


def test_defaults_load_and_keywords_override():
    config = load_config(camera=True, camera_resolution=64, sensors={"rays_per_side": 3})
    assert config.sensors.camera is True
    assert config.sensors.camera_resolution == 64
    assert config.sensors.rays_per_side == 3
    assert config.physics.timestep * config.physics.action_repeat == pytest.approx(0.02)


def test_user_yaml_overrides_defaults(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("episode:\n  max_steps: 500\nagent:\n  body: quadruped16\n")
    config = load_config(path)
    assert config.episode.max_steps == 500
    assert config.agent.body == "quadruped16"


@pytest.mark.parametrize(
    "overrides, names",
    [
        ({"difficulty": 11}, ["difficulty", "11", "0 to 10"]),
        ({"rays_per_side": 0}, ["sensors.rays_per_side", "0", "1 to 20"]),
        ({"camera_resolution": 4}, ["sensors.camera_resolution", "4", "8 to 512"]),
        ({"max_steps": 5}, ["episode.max_steps", "5", "10 to 10000"]),
        ({"ray_max_angle": 200}, ["sensors.ray_max_angle", "200", "5 to 180"]),
        ({"camera": "yes"}, ["sensors.camera", "'yes'", "true or false"]),
        ({"body": "spider"}, ["agent.body", "'spider'", "quadruped, quadruped16"]),
        ({"camra": True}, ["camra", "does not exist", "camera"]),
        ({"sensors": {"camra": True}}, ["sensors.camra", "does not exist", "sensors.camera"]),
    ],
)
def test_bad_values_name_key_value_and_what_is_allowed(overrides, names):
    with pytest.raises(ConfigError) as caught:
        load_config(**overrides)
    for name in names:
        assert name in str(caught.value)


def test_unknown_key_in_user_yaml(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("episode:\n  max_stepz: 500\n")
    with pytest.raises(ConfigError, match=r"episode\.max_stepz.*does not exist.*episode\.max_steps"):
        load_config(path)


def test_missing_config_file_is_named():
    with pytest.raises(ConfigError, match="nope.yaml.*does not exist"):
        load_config("nope.yaml")


def test_env_rejects_bad_level_and_difficulty():
    with pytest.raises(ConfigError, match="level 42 does not exist"):
        AnimalAIEnv(level=42)
    with pytest.raises(ConfigError, match="difficulty: got 11"):
        AnimalAIEnv(level=0, difficulty=11)


def test_missing_model_file_is_named(monkeypatch, tmp_path):
    monkeypatch.setattr("aaai.agent.body.URDF_DIR", tmp_path)
    with pytest.raises(FileNotFoundError, match="agent.body='quadruped'.*quadruped.urdf"):
        urdf_path("quadruped")


def test_level_parameters_follow_difficulty():
    assert [resolve_value("round(0.4 * d + 1)", d, "x") for d in (0, 5, 10)] == [1, 3, 5]
    assert resolve_value([4, 4, 4, 4, 4, 3, 3, 3, 2, 2, 2], 8, "x") == 2
    assert resolve_value("clamp(3 + floor(d / 3), 2, 5) - 1", 10, "x") == 4
    with pytest.raises(LevelParamError, match="'__import__\\(.os.\\)' is not allowed"):
        resolve_value("__import__('os')", 0, "x")
    with pytest.raises(LevelParamError, match="parameter 'food_sise' does not exist"):
        resolve({"food_sise": 1}, 0, ("food_size",), "L0.yaml")
    with pytest.raises(LevelParamError, match="list of 11"):
        resolve_value([1, 2, 3], 0, "x")


@pytest.mark.parametrize(
    "expression, words",
    [
        ("9**9**9", "is too large to compute"),  # would compute a number of 370 million digits
        ("ceil(2**2000 / 1.5)", "is too large to compute"),
        ("round(1e400)", "is too large to compute"),
        ("floor(1e400 - 1e400)", "cannot convert float NaN to integer"),
        ("(-8) ** 0.5", "not a real number"),
        ("-" * 100000 + "1", "an expression of 100,001 characters; allowed: .* of at most 200"),
    ],
    ids=["power", "division", "infinity", "nan", "complex", "long"],
)
def test_a_level_parameter_expression_that_cannot_be_computed_gets_one_clear_message(expression, words):
    started = time.perf_counter()
    with pytest.raises(LevelParamError, match=rf"^L0.yaml: parameter 'n': .*{words}"):
        resolve_value(expression, 3, "L0.yaml: parameter 'n'")
    assert time.perf_counter() - started < 1
    assert resolve_value("2 ** d", 3, "x") == 8 and resolve_value("2 ** 0.5", 3, "x") == pytest.approx(2**0.5)


def test_bad_seed_is_rejected():
    with pytest.raises(ConfigError, match="seed: got -1"):
        generate(0, 0, -1)


@pytest.mark.parametrize(
    "time_limit, words",
    [
        ("500", ["time_limit", "500", "0.2 to 200 seconds"]),
        ('"10 * d"', ["time_limit", "0.0", "difficulty 0"]),
    ],
)
def test_a_level_file_with_a_bad_time_limit_is_refused(tmp_path, time_limit, words):
    from aaai.levels import _load_level

    text = (config_dir() / "levels" / "L0.yaml").read_text()
    path = tmp_path / "L0.yaml"
    path.write_text(
        "\n".join(f"time_limit: {time_limit}" if line.startswith("time_limit:") else line for line in text.splitlines())
    )
    with pytest.raises(ConfigError) as error:
        _load_level(path)
    assert all(word in str(error.value) for word in words)


def test_an_episode_lasts_its_levels_time_limit_unless_max_steps_is_set(make_env):
    from aaai.levels import get_level

    for level, difficulty in ((0, 0), (11, 10)):
        env = make_env()
        _, info = env.reset(seed=1, options={"level": level, "difficulty": difficulty})
        seconds = get_level(level).time_limit_at(difficulty)
        assert info["max_steps"] == round(seconds / env.control_dt) and seconds > 15
    env = make_env(max_steps=40)
    env.reset(seed=1)
    for step in range(1, 41):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert truncated == (step == 40) and not terminated and info["max_steps"] == 40


@pytest.mark.parametrize("keyword", ["frameskip", "seed", "total_steps", "levels", "camra"])
def test_the_env_refuses_an_unknown_or_training_keyword_as_python_does(keyword):
    import gymnasium as gym

    import aaai  # noqa: F401  (registers the ids)

    with pytest.raises(
        TypeError, match=rf"__init__\(\) got an unexpected keyword argument '{keyword}'; allowed: .*camera"
    ) as refused:
        gym.make("aaai/L0-FoodContact-v0", **{keyword: 1})
    allowed = str(refused.value).split("; allowed: ")[1].split(" was raised")[0].split(", ")
    assert len(allowed) == len(set(allowed)) and {"level", "difficulty", "arena"} <= set(allowed)


@pytest.mark.parametrize("text", ["5-2", "0-3000000000", "0-13", "-1", "x"])
def test_a_bad_range_is_refused_before_any_list_is_built(text):
    from aaai.config import parse_int_set

    with pytest.raises(ConfigError, match=rf"got '{text}'; allowed: integers from 0 to 12"):
        parse_int_set(text, "curriculum.levels", 0, 12)


def test_importing_aaai_prints_nothing():
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-c", "import aaai"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout == "" and result.stderr == ""


@pytest.mark.parametrize(
    "content, words",
    [
        (b"a: &x [1, 2]\nb: *x\n", ["alias", "not allowed"]),
        (b"lol1: &l1 [a, a, a, a, a, a, a, a, a]\nlol2: &l2 [*l1, *l1, *l1, *l1, *l1, *l1]\n", ["alias"]),
        (b"episode:\n  max_steps: 500\n\xff\xfe\n", ["not UTF-8"]),
        (b"[" * 5000 + b"]" * 5000, ["nests too deeply"]),
        (b"- 1\n- 2\n", ["top level must be a mapping"]),
        (b"train:\n  total_steps: " + b"9" * 500 + b"\n", ["line 2", "an integer of 500 digits", "at most 40"]),
        (b"train:\n  learning_rate: 1.0e+500\n", ["line 2", "too large for a float"]),
        (b"episode: !!python/object/apply:os.system [echo]\n", ["line 1", "tag !!python/object/apply:os.system"]),
        (b'"episode\\0": {max_steps: 500}\n', ["line 1", "a NUL character"]),
    ],
)
def test_a_hostile_yaml_file_gets_one_clear_message(tmp_path, content, words):
    path = tmp_path / "bad.yaml"
    path.write_bytes(content)
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert str(path) in str(error.value) and all(word in str(error.value) for word in words)


@pytest.mark.parametrize("value", [10**500, -(10**500), 2**64], ids=["1e500", "-1e500", "2**64"])
def test_a_huge_integer_value_is_refused_as_out_of_range(value):
    with pytest.raises(ConfigError, match=r"'train.total_steps': got .*allowed: an integer from 1 to 1e\+10"):
        load_config(total_steps=value)
    with pytest.raises(ConfigError, match=r"config key 'train.learning_rate': got .*allowed: a number from"):
        load_config(learning_rate=value)


def test_a_config_that_is_neither_a_path_nor_a_mapping_is_refused():
    with pytest.raises(ConfigError, match="got 123; allowed: a YAML file's path or a mapping"):
        load_config(123)


@pytest.mark.parametrize(
    "key, value",
    [("ray_memory", 7), ("food_memory", 4), ("ray_down_fan", 8.0), ("ray_width", 1.0)],
    ids=["memory", "food_memory", "fan", "width"],
)
def test_an_option_of_the_rays_with_the_rays_off_is_refused_not_ignored(key, value):
    with pytest.raises(ConfigError, match=rf"'sensors.{key}': got {value!r} with 'sensors.rays': false"):
        load_config(sensors={"rays": False, key: value})
    assert getattr(load_config(sensors={"rays": True, key: value}).sensors, key) == value
    assert load_config(sensors={"rays": False, key: 0}).sensors.rays is False


def test_the_config_is_typed_and_frozen_and_read_by_attribute():
    from dataclasses import FrozenInstanceError

    config = load_config(num_envs=3, levels="0-2,5", action_mode="gait")
    assert config.train.num_envs == 3 and config.agent.action_mode == "gait"
    assert config.curriculum.levels == (0, 1, 2, 5)  # a set of ids, immutable
    with pytest.raises(TypeError):
        config["train"]  # no string keys: every read is an attribute a type checker follows
    with pytest.raises(FrozenInstanceError):
        config.train.num_envs = 4
    again = config.replace(num_envs=5)
    assert (again.train.num_envs, config.train.num_envs) == (5, 3)
    assert config.replace({"train": {"seed": 9}}).train.seed == 9
    with pytest.raises(ConfigError, match="train.num_envs.*0.*1 to 256"):
        config.replace(num_envs=0)  # a copy is checked as a new config is


def test_the_config_file_keeps_its_format():
    """Run folders, model files and provenance digests hold ``to_yaml()``: the dotted keys in the order
    of configs/default.yaml, plain YAML data, read back to the same config."""
    import yaml

    from aaai.config import read_yaml

    def dotted(tree, prefix=""):
        for key, value in tree.items():
            yield from dotted(value, f"{prefix}{key}.") if isinstance(value, dict) else [f"{prefix}{key}"]

    config = load_config(levels="0-3,5", difficulties=[4, 1], camera=True, init_from="runs/x")
    assert list(config.flat()) == list(dotted(read_yaml(config_dir() / "default.yaml")))
    assert list(dotted(config.to_dict())) == list(config.flat())
    text = config.to_yaml()
    assert text == yaml.safe_dump(config.to_dict(), sort_keys=False)
    assert "  levels:\n  - 0\n  - 1\n  - 2\n  - 3\n  - 5\n" in text  # a plain list, as before
    assert load_config(yaml.safe_load(text)) == config
    assert set(config.env_dict()) == set(config.to_dict()) - {"curriculum", "train", "eval"}


def test_the_envs_keywords_are_typed_and_listed_in_its_docstring():
    from aaai.config import env_keywords
    from aaai.env import EnvKeywords

    assert set(EnvKeywords.__annotations__) == env_keywords() - {"level", "difficulty"}  # named arguments
    for name in env_keywords() - {"agent", "sensors", "episode", "physics"}:
        assert f"- ``{name}`` (" in AnimalAIEnv.__doc__, name


@pytest.mark.parametrize("action_mode, drive", [("rotation", "angle"), ("gait", "angle"), ("velocity", "velocity")])
def test_the_body_drive_is_named_apart_from_the_action_mode(action_mode, drive):
    env = AnimalAIEnv(action_mode=action_mode, rays=False)
    try:
        assert env.body.drive == drive and env.action_mode == action_mode
    finally:
        env.close()


def test_the_body_has_visual_shapes_only_when_something_draws():
    bare, seen = (
        AnimalAIEnv(rays=False),
        AnimalAIEnv(rays=False, camera=True, camera_resolution=8, camera_look="classic"),
    )
    try:
        assert bare.body.path == str(urdf_path("quadruped", visuals=False))
        assert seen.body.path == str(urdf_path("quadruped", visuals=True)) != bare.body.path
    finally:
        bare.close()
        seen.close()
