"""A student that sees: DAgger from the camera (configs/student_camera*.yaml), its data's memory, its scoring."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from gymnasium import spaces

pytest.importorskip("stable_baselines3", reason="needs the train extra")

from aaai.config import ConfigError, env_part, load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.scoring.model_archive import read_archive  # noqa: E402
from aaai.train.camera_student import (  # noqa: E402
    Dataset,
    as_stored,
    check_memory,
    decision_bytes,
    keep_round,
    seen_space,
)
from aaai.train.student import fit, train_student  # noqa: E402
from aaai.train.training import with_proprioception  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
CAMERA, PROPRIO = CONFIGS / "student_camera.yaml", CONFIGS / "student_camera_proprio.yaml"
SMALL = dict(  # the shipped config on one cell, two short rounds, 36 px (NatureCNN's least)
    levels="0",
    difficulties="0",
    dagger_iterations=2,
    dagger_episodes=1,
    dagger_episode_cap=15,
    dagger_epochs=1,
    dagger_max_decisions=20,
    net_width=32,
    num_envs=1,
    camera_resolution=36,
)


@pytest.fixture(scope="module")
def camera_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("camera") / "student"
    result = train_student(run, load_config(CAMERA, **SMALL), say=lambda message: None)
    return run, result


@pytest.mark.parametrize("path", [CAMERA, PROPRIO], ids=["camera", "camera+proprioception"])
def test_a_camera_students_observation_is_the_image_and_not_the_rays(path):
    config = with_proprioception(load_config(path))
    env = AnimalAIEnv(config=env_part(config, 0.0))
    try:
        observation, _ = env.reset(seed=3, options={"level": 0, "difficulty": 0})
        assert "rays" not in observation and "ray_memory" not in observation
        image = observation["camera"]
        assert image.shape == (64, 64, 3) and image.dtype == np.uint8 and image.any()
        body = {"joint_velocities", "head_orientation", "foot_contacts"}
        assert body <= set(observation) if path == PROPRIO else not body & set(observation)
        assert seen_space(env.observation_space)["camera"].shape == (3, 64, 64)  # what the CNN reads
        stored = as_stored({key: [value, value] for key, value in observation.items()}, env.observation_space)
        assert stored["camera"].shape == (2, 3, 64, 64) and stored["camera"].dtype == np.uint8
        assert np.array_equal(stored["camera"][1], image.transpose(2, 0, 1))
    finally:
        env.close()


def test_one_dagger_round_from_the_camera_trains_and_saves_a_model_that_loads_without_trust(camera_run):
    run, result = camera_run
    assert result.episodes == 2 and result.steps == 20  # two rounds of 10 kept decisions (the cap)
    assert (run / "final" / "model.zip").is_file()
    lines = (run / "dagger.csv").read_text().splitlines()
    assert len(lines) == 3 and lines[2].startswith("1,0.5,1,15,")  # round 1: the student drove half
    kwargs = read_archive(run / "final" / "model.zip").data["policy_kwargs"]
    assert "features_extractor_class" not in kwargs  # MultiInputPolicy's own CombinedExtractor: NatureCNN
    with np.load(run / "dagger" / "iteration_001.npz") as data:
        assert data["obs_camera"].shape == (10, 3, 36, 36) and data["obs_camera"].dtype == np.uint8
        assert "obs_rays" not in data.files
        last = data["obs_camera"]
    resumed = Dataset(20)  # what --resume reads back: the rounds, one at a time, into the one buffer
    resumed.load(run / "dagger", 2)
    assert resumed.size == 20 and np.array_equal(resumed.observations["camera"][10:], last)
    assert resumed.nbytes == 20 * (3 * 36 * 36 + 8 * 4 + 3 * 4)  # camera, joint angles, label


def test_the_camera_student_scores_through_aaai_eval(camera_run, tmp_path):
    run, _ = camera_run
    short = yaml.safe_load((run / "config.yaml").read_text())
    short["episode"]["max_steps"] = 20
    config = tmp_path / "short.yaml"
    config.write_text(yaml.safe_dump(short))
    out = tmp_path / "scores.csv"
    scored = CliRunner().invoke(
        cli,
        ["eval", "--policy", str(run), "--levels", "0", "--difficulty", "0", "-k", "1"]
        + ["--config", str(config), "--out", str(out)],
    )
    assert scored.exit_code == 0, scored.output
    assert len(out.read_text().splitlines()) == 2  # the header and the one episode


IMAGE = spaces.Box(0, 255, (3, 36, 36), np.uint8)
SPACE = spaces.Dict({"joints": spaces.Box(-1.0, 1.0, (8,), np.float32), "camera": IMAGE})


def _round(rng: np.random.Generator, sizes: list[int]) -> list[dict]:
    return [
        {
            "observations": {
                "joints": rng.random((n, 8), dtype=np.float32),
                "camera": rng.integers(0, 256, (n, *IMAGE.shape), dtype=np.uint8),
            },
            "labels": rng.random((n, 3), dtype=np.float32),
            "starts": np.arange(n) % 10 == 0,
        }
        for n in sizes
    ]


def test_the_labelled_data_stays_within_its_stated_bound():
    rng = np.random.default_rng(0)
    size = decision_bytes(SPACE, (3,))
    assert size == 3 * 36 * 36 + 8 * 4 + 3 * 4  # images as uint8: a byte a pixel and channel
    iterations, cap = 4, 100
    data = Dataset(cap)
    for iteration in range(iterations):
        results = _round(rng, [30, 7, 40])  # 77 decisions, of which a round keeps cap / iterations
        observations, labels, starts = keep_round(results, cap // iterations, np.random.default_rng([0, iteration]))
        assert len(labels) == 25 and observations["camera"].dtype == np.uint8
        assert starts.all()  # a sample's decisions are sequences of one (for a stateless student)
        everything = np.concatenate([r["labels"] for r in results])
        assert (np.isin(labels, everything).all(axis=1)).all()  # a sample of the round's own decisions
        data.add(observations, labels)
        assert data.size <= cap and data.nbytes == cap * size  # one buffer, allocated once
    assert data.size == cap
    with pytest.raises(ValueError, match="100 decisions"):
        data.add(observations, labels)
    few = _round(rng, [5])
    kept, labels, starts = keep_round(few, 25, rng)  # a round with fewer decisions keeps them all, in order
    assert np.array_equal(labels, few[0]["labels"]) and np.array_equal(starts, few[0]["starts"])


def test_the_refit_reads_the_images_as_uint8_batches(monkeypatch):
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy

    rng = np.random.default_rng(1)
    results = _round(rng, [64])
    policy = MultiInputActorCriticPolicy(SPACE, spaces.Box(-1, 1, (3,), np.float32), lambda _: 1e-3, net_arch=[8])
    seen = []
    inner = policy.extract_features
    monkeypatch.setattr(
        policy, "extract_features", lambda obs, ext: seen.append(obs["camera"].dtype) or inner(obs, ext)
    )
    fit(policy, results[0]["observations"], results[0]["labels"], epochs=1, seed=0)
    import torch

    assert seen and set(seen) == {torch.uint8}  # no float copy of the data: each batch is made floats in the CNN


def test_a_camera_student_without_a_cap_on_its_data_is_refused_before_its_run_exists(tmp_path, monkeypatch):
    with pytest.raises(ConfigError, match=r"'train.dagger_max_decisions': got 0 \(no cap\) .* could reach 7\.\d\d GiB"):
        check_memory(load_config(CAMERA, dagger_max_decisions=0))  # 8 x 143 x 600 decisions of 12,332 bytes
    assert check_memory(load_config(CAMERA))[0] == 200_000
    small = load_config(CAMERA, dagger_max_decisions=0, camera_resolution=36, dagger_episodes=20)
    assert check_memory(small) == (None, 3 * 36 * 36 + 8 * 4 + 3 * 4)  # 96,000 decisions: 0.36 GiB at most
    # With no cap on an episode (0), each is counted at the longest a level lasts: 200 s, 2,000 decisions
    # of 0.1 s; 8 rounds x 68 episodes of them fit in 4 GiB, 8 x 69 do not.
    assert check_memory(load_config(small, dagger_episode_cap=0, dagger_episodes=68))[0] is None
    with pytest.raises(ConfigError, match=r"could reach 4\.0\d GiB \(1,104,000 decisions of 3,932 bytes"):
        check_memory(load_config(small, dagger_episode_cap=0, dagger_episodes=69))
    uncapped = yaml.safe_load(CAMERA.read_text())
    uncapped["train"]["dagger_max_decisions"] = 0
    path = tmp_path / "uncapped.yaml"
    path.write_text(yaml.safe_dump(uncapped))
    monkeypatch.setattr("aaai.train.student.ProcessPoolExecutor", None)  # were it not refused: no episodes
    refused = CliRunner().invoke(cli, ["train", "--config", str(path), "--run", str(tmp_path / "run")])
    assert refused.exit_code != 0 and "train.dagger_max_decisions" in refused.output
    assert "Traceback" not in refused.output and not (tmp_path / "run").exists()
