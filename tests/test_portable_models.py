"""Models and runs made here load and act elsewhere: a model's spaces are compared with the
environment's by value on every supported Gymnasium, a camera run plays through every command, and a
model file carries the config it was trained with (the committed models included)."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import needs

from aaai.config import ConfigError, load_config
from aaai.env import AnimalAIEnv
from aaai.scoring import model_spaces
from aaai.scoring.model_archive import Archive
from aaai.scoring.model_config import CONFIG_MEMBER, model_config
from aaai.scoring.model_spaces import space_problems
from aaai.scoring.policies import resolve
from aaai.scoring.runs import RunFolder
from aaai_cli.main import cli

MODELS = Path(__file__).resolve().parent.parent / "baselines" / "models"
CAMERA = {
    "level": 0,
    "difficulty": 0,
    "curriculum": {"levels": [0], "difficulties": [0]},
    "sensors": {"camera": True, "camera_resolution": 36},
    "episode": {"max_steps": 10},
    "train": {
        "num_envs": 1,
        "n_steps": 16,
        "batch_size": 16,
        "n_epochs": 1,
        "total_steps": 16,
        "net_width": 8,
        "checkpoint_every": 1000,
        "heatmap_every": 1000,
    },
}


def _quiet(message: str) -> None:
    pass


@pytest.fixture(scope="module")
def camera_run(tmp_path_factory) -> Path:
    """A PPO run that sees through the camera (36 x 36 pixels, the CNN's smallest), 16 steps long."""
    needs("stable_baselines3", "train")
    from aaai.train.training import train

    folder = tmp_path_factory.mktemp("camera") / "run"
    train(folder, load_config(CAMERA), asynchronous=False, say=_quiet)
    return folder


def _invoke(*arguments: str):
    result = CliRunner().invoke(cli, list(arguments))
    assert result.exit_code == 0, result.output
    return result


# --- a camera run through every command -----------------------------------------------------------
def test_a_camera_run_is_scored_run_and_shown_acting_as_stable_baselines3_acts(camera_run, tmp_path):
    """stable-baselines3 hands its policy channel-first images (C x H x W); the environment's are
    H x W x C. The run is scored, run and filmed, and the model read without code acts exactly as
    stable-baselines3's own loader (--trust-model) acts on the same observations."""
    _invoke("eval", "--policy", str(camera_run), "--seeds", "1", "--out", str(tmp_path / "s.csv"))
    assert (tmp_path / "s.csv").read_text().count("\n") == 2  # the header and the episode
    _invoke("run", "--policy", str(camera_run), "--max-steps", "10")
    video = tmp_path / "v.mp4"
    _invoke("show", "0", "--policy", str(camera_run), "--video", str(video), "--steps", "2", "--size", "200")
    assert video.stat().st_size > 0
    env = AnimalAIEnv(config=resolve(str(camera_run)).play_config())
    try:
        assert env.observation_space["camera"].shape == (36, 36, 3)
        safe, trusted = resolve(str(camera_run)).build(env), resolve(str(camera_run), trust=True).build(env)
        observation, _ = env.reset(seed=3)
        for _ in range(3):
            action = safe(observation)
            assert np.array_equal(action, trusted(observation))
            observation, *_ = env.step(action)
    finally:
        env.close()


def test_a_camera_run_is_resumed_and_fine_tuned(camera_run, tmp_path):
    from aaai.train.training import train

    resumed = tmp_path / "resumed"
    shutil.copytree(camera_run, resumed)
    result = train(resumed, resume=True, total_steps=32, asynchronous=False, say=_quiet)
    assert result.resumed_from == 16 and result.steps == 32
    tuned = train(
        tmp_path / "tuned",
        load_config(CAMERA, init_from=str(camera_run)),
        asynchronous=False,
        say=_quiet,
    )
    assert tuned.steps == 16 and (tmp_path / "tuned" / "final" / "model.zip").is_file()


# --- a model file carries its config ----------------------------------------------------------------
def test_a_model_file_carries_its_runs_config_and_is_scored_with_it_alone(camera_run, tmp_path):
    """The file copied out of its run is scored on its own in the camera it was trained with;
    --config still overrides, and one the model was not trained in is refused, naming the key."""
    bare = tmp_path / "camera.zip"
    shutil.copy(camera_run / "final" / "model.zip", bare)
    run_config = load_config(RunFolder(camera_run).read_config())
    assert model_config(bare) == run_config
    assert resolve(str(bare)).config() == run_config
    _invoke("eval", "--policy", str(bare), "--seeds", "1", "--out", str(tmp_path / "s.csv"))
    other = tmp_path / "other.yaml"
    other.write_text("sensors:\n  camera: true\n  camera_resolution: 48\n")
    refused = CliRunner().invoke(cli, ["eval", "--policy", str(bare), "--seeds", "1", "--config", str(other)])
    assert refused.exit_code != 0
    assert "sensors.camera_resolution: model 36, environment 48" in refused.output, refused.output
    assert "the config the file carries (leave out --config)" in refused.output, refused.output


def test_a_model_file_whose_config_does_not_load_is_refused_naming_it(camera_run, tmp_path):
    damaged = tmp_path / "damaged.zip"
    with zipfile.ZipFile(camera_run / "final" / "model.zip") as source, zipfile.ZipFile(damaged, "w") as target:
        for name in source.namelist():
            if name != CONFIG_MEMBER:
                target.writestr(name, source.read(name))
        target.writestr(CONFIG_MEMBER, "sensors:\n  camera_resolution: -3\n")
    with pytest.raises(ConfigError) as caught:
        resolve(str(damaged))
    assert str(caught.value).startswith(f"model file {str(damaged)!r}: the config it carries ({CONFIG_MEMBER})")
    assert "camera_resolution" in str(caught.value)


def test_the_committed_models_are_scored_with_the_config_they_carry(tmp_path):
    """No --config: each committed model carries the config of the run that trained it (its YAML
    beside it), and loads in its environment on this Gymnasium."""
    needs("stable_baselines3", "train")
    for name in ("student", "student_food_memory", "ppo_gait"):
        policy = resolve(str(MODELS / f"{name}.zip"))
        assert policy.config() == load_config(str(MODELS / f"{name}.yaml")), name
        env = AnimalAIEnv(config=policy.play_config())
        try:
            observation, _ = env.reset(seed=1)
            assert env.action_space.contains(policy.build(env)(observation))
        finally:
            env.close()
    scored = _invoke(
        "eval",
        "--policy",
        str(MODELS / "student.zip"),
        "--levels",
        "0",
        "--difficulty",
        "0",
        "--seeds",
        "1",
        "--out",
        str(tmp_path / "student.csv"),
    )
    assert "| L0 food_contact | 1 |" in scored.output and "| 100% |" in scored.output, scored.output


# --- spaces by value --------------------------------------------------------------------------------
def _archive(action_entry: dict, spaces_text: str) -> Archive:
    observation = {":type:": "<class 'gymnasium.spaces.dict.Dict'>", "spaces": spaces_text}
    return Archive(Path("m.zip"), {"observation_space": observation, "action_space": action_entry}, [])


BOX = "<class 'gymnasium.spaces.box.Box'>"


@pytest.mark.parametrize(
    "low_repr, high_repr",
    [("[-1. -1.  0.]", "1.0"), (None, None)],  # as Gymnasium 1.0-1.3 keep it; as 1.4 does (filled only when printed)
)
def test_spaces_are_compared_by_value_whatever_form_the_file_keeps(low_repr, high_repr):
    from gymnasium import spaces

    action = spaces.Box(np.array([-1.0, -1.0, 0.0], np.float32), 1.0, (3,), np.float32)
    observation = spaces.Dict({"camera": spaces.Box(0, 255, (36, 36, 3), np.uint8)})
    entry = {
        ":type:": BOX,
        "dtype": "float32",
        "_shape": [3],
        "low": "[-1. -1.  0.]",
        "high": "[1. 1. 1.]",
        "low_repr": low_repr,
        "high_repr": high_repr,
    }
    stored = "{'camera': Box(0, 255, (3, 36, 36), uint8)}"  # channel-first, as stable-baselines3 keeps images
    assert space_problems(_archive(entry, stored), observation, action) == []
    other = spaces.Box(np.array([-1.0, -1.0, -1.0], np.float32), 1.0, (3,), np.float32)
    problems = space_problems(_archive(entry, stored), observation, other)
    assert problems == [
        f"action space: model Box({low_repr or '[-1. -1.  0.]'}, {high_repr or '[1. 1. 1.]'}, (3,), float32), "
        "environment Box(-1.0, 1.0, (3,), float32)"
    ]
    smaller = spaces.Dict({"camera": spaces.Box(0, 255, (32, 32, 3), np.uint8)})
    assert space_problems(_archive(entry, stored), smaller, action) == [
        "observation 'camera': model Box(0, 255, (3, 36, 36), uint8), environment Box(0, 255, (3, 32, 32), uint8)"
    ]


def test_bounds_a_file_shortened_are_not_compared_but_shape_and_dtype_are():
    from gymnasium import spaces

    shortened = "{'big': Box([0. 0. 0. ... 0. 0. 0.], 1.0, (2000,), float32)}"  # numpy prints '...' past 1000
    stored = model_spaces.stored_space(_archive({}, shortened), "observation_space")
    assert stored is not None
    live = model_spaces.describe_space(spaces.Dict({"big": spaces.Box(0.0, 1.0, (2000,), np.float32)}))
    assert model_spaces.compare_spaces("observation", stored, live) == []
    wider = model_spaces.describe_space(spaces.Dict({"big": spaces.Box(0.0, 1.0, (2000,), np.float64)}))
    assert len(model_spaces.compare_spaces("observation", stored, wider)) == 1
