"""Resuming a run: from the newest saved point, past damaged ones, never backwards; and models that
cannot be loaded refused with the file named."""

import csv
import json
import re
import zipfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError, load_config
from aaai.scoring.policies import ModelPolicy, resolve
from aaai.scoring.runs import RunFolder, model_problem
from aaai.train.training import train
from aaai_cli.main import cli

SMALL = {
    "episode": {"max_steps": 100},
    "curriculum": {"levels": "0", "difficulties": "0"},
    "train": {
        "checkpoint_every": 400,
        "heatmap_every": 400,
        "n_steps": 64,
        "batch_size": 64,
        "n_epochs": 1,
        "net_width": 16,
        "num_envs": 2,
    },
}


def start(run: Path, agent: str, steps: int) -> None:
    config = load_config({**SMALL, "train": {**SMALL["train"], "agent": agent, "total_steps": steps}})
    train(run, config, asynchronous=False)


def step_of(folder: Path) -> int:
    return json.loads((folder / "state.json").read_text())["step"]


def episode_rows(run: Path) -> list[list[str]]:
    with open(run / "episodes.csv", newline="") as handle:
        return list(csv.reader(handle))[1:]


@pytest.fixture(scope="module")
def random_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("random") / "run"
    start(run, "random", 1000)
    return run


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("ppo") / "run"
    start(run, "ppo", 900)
    return run


def copy_of(run: Path, tmp_path: Path) -> Path:
    import shutil

    shutil.copytree(run, tmp_path / "run")
    return tmp_path / "run"


def test_a_finished_run_resumes_from_final_and_keeps_every_logged_episode(random_run, tmp_path):
    run = copy_of(random_run, tmp_path)
    assert step_of(run / "final") == 1000 and step_of(run / "checkpoints" / f"step_{800:012d}") == 800
    before = episode_rows(run)
    said = []
    result = train(run, resume=True, total_steps=1600, asynchronous=False, say=said.append)
    assert result.resumed_from == 1000 and said == []  # from final/, not from the step-800 checkpoint
    assert step_of(run / "final") == 1600
    after = episode_rows(run)
    assert after[: len(before)] == before and len(after) > len(before)


def test_a_damaged_newest_point_is_skipped_with_a_message(random_run, tmp_path):
    run = copy_of(random_run, tmp_path)
    (run / "final" / "state.json").write_text('{"step": 10')  # torn by a crash
    said = []
    result = train(run, resume=True, total_steps=1200, asynchronous=False, say=said.append)
    assert result.resumed_from == 800
    assert len(said) == 1 and "final" in said[0] and "state.json" in said[0] and "older checkpoint" in said[0]
    assert said[0] in (run / "resume.log").read_text()
    assert step_of(run / "final") == 1200


def test_no_readable_point_is_an_error_naming_what_was_tried(random_run, tmp_path):
    run = copy_of(random_run, tmp_path)
    for folder in RunFolder(run).saved():
        (folder / "state.json").write_text("not json")
    with pytest.raises(ConfigError, match=r"no checkpoint .* can be read .*final.*step_000000000400"):
        train(run, resume=True, asynchronous=False, say=lambda message: None)


def test_steps_below_what_the_run_has_done_are_refused(random_run, tmp_path):
    run = copy_of(random_run, tmp_path)
    with pytest.raises(ConfigError, match=r"--steps: got 500; the run already has 1000 steps .*more than 1000"):
        train(run, resume=True, total_steps=500, asynchronous=False)
    assert step_of(run / "final") == 1000  # nothing replaced
    with pytest.raises(ConfigError, match="got 1000"):
        train(run, resume=True, total_steps=1000, asynchronous=False)


def test_a_damaged_config_is_named(random_run, tmp_path):
    run = copy_of(random_run, tmp_path)
    (run / "config.yaml").write_text("train: [unclosed\n")
    with pytest.raises(ConfigError, match=r"config\.yaml.* is not valid YAML"):
        train(run, resume=True, asynchronous=False)
    result = CliRunner().invoke(cli, ["eval", "--policy", str(run), "-k", "1", "--levels", "0", "--difficulty", "0"])
    assert result.exit_code == 2 and "config.yaml" in result.output and "Traceback" not in result.output


def test_ppo_resume_skips_a_damaged_final_model(ppo_run, tmp_path):
    run = copy_of(ppo_run, tmp_path)
    assert step_of(run / "final") >= 900 and model_problem(run / "final" / "model.zip") is None
    (run / "final" / "model.zip").write_bytes((run / "final" / "model.zip").read_bytes()[:500])
    said = []
    result = train(run, resume=True, total_steps=1100, asynchronous=False, say=said.append)
    assert result.resumed_from == 800 and "final" in said[0] and "model.zip" in said[0]
    assert model_problem(run / "final" / "model.zip") is None and step_of(run / "final") >= 1100


@pytest.mark.parametrize(
    "damage, problem",
    [
        (lambda path: path.write_bytes(b""), "is empty"),
        # torn at the end: the archive's index is gone (what is left may open as the zip nested inside)
        (lambda path: path.write_bytes(path.read_bytes()[:-200]), "(not a whole zip archive|not a stable-baselines3)"),
        (lambda path: path.write_bytes(b"PK" + bytes(300)), "not a whole zip archive"),
        (lambda path: zipfile.ZipFile(path, "w").writestr("notes.txt", "hello"), "not a stable-baselines3 model"),
    ],
)
def test_eval_refuses_a_damaged_model_naming_it(ppo_run, tmp_path, damage, problem):
    run = copy_of(ppo_run, tmp_path)
    damage(run / "final" / "model.zip")
    with pytest.raises(
        ConfigError, match=rf"newest model of run .*final.*{problem}.*checkpoints/step_000000000800/model.zip"
    ):
        resolve(str(run))
    bare = tmp_path / "model.zip"
    damage_copy = (run / "final" / "model.zip").read_bytes()
    bare.write_bytes(damage_copy)
    result = CliRunner().invoke(
        cli,
        [
            "eval",
            "--policy",
            str(bare),
            "-k",
            "1",
            "--levels",
            "0",
            "--difficulty",
            "0",
            "--out",
            str(tmp_path / "board.csv"),
        ],
    )
    assert result.exit_code == 2 and "model.zip" in result.output and re.search(problem, result.output)
    assert not (tmp_path / "board.csv").exists()


def test_a_model_that_loads_is_scored_from_the_newest_point(ppo_run):
    assert resolve(str(ppo_run)).file == str(ppo_run / "final" / "model.zip")


def test_a_model_stable_baselines3_cannot_read_is_a_clear_error(ppo_run, tmp_path):
    path = tmp_path / "model.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", "{not json")
        archive.writestr("policy.pth", b"nothing")
    with pytest.raises(ConfigError, match="cannot be loaded by stable-baselines3"):
        ModelPolicy(resolve(str(path)).file, env=None)
