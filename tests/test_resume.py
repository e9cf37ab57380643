"""Resuming a run: from the newest saved point, past damaged ones, never backwards; models that
cannot be loaded refused with the file named; a full disk or a refused permission while training is
one line naming the file, with nothing half-written left."""

import csv
import errno
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


# --- a full disk, a permission refused ---------------------------------------------------------------
def no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")  # as a write to a full disk: no file named


def tiny_config(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(
        "episode: {max_steps: 20}\ncurriculum: {levels: '0', difficulties: '0'}\n"
        "train: {checkpoint_every: 60, heatmap_every: 1000000, num_envs: 1, vector: sync}\n"
    )
    return path


def test_a_full_disk_at_a_checkpoint_is_one_line_naming_the_file_and_the_run_resumes(tmp_path, monkeypatch):
    run, config = tmp_path / "run", tiny_config(tmp_path)
    write_text, states = Path.write_text, []

    def full_at_state(self, *args, **kwargs):  # state.json of the second checkpoint cannot be written
        if self.name.startswith(".state."):
            states.append(self)
            if len(states) == 2:
                no_space()
        return write_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full_at_state)
    result = CliRunner().invoke(
        cli, ["train", "--agent", "random", "--steps", "1000", "--config", str(config), "--run", str(run)]
    )
    monkeypatch.setattr(Path, "write_text", write_text)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1 and len(lines) == 1 and "Traceback" not in result.output, result.output
    assert f"cannot write {str(run / 'checkpoints' / f'step_{120:012d}' / 'state.json')!r}: No space left" in lines[0]
    assert f"aaai train --resume {run}" in lines[0]
    assert not list(run.rglob(".staging-*")) and not list(run.rglob(".state.*"))  # nothing half-written left
    assert [p.name for p in (run / "checkpoints").iterdir()] == [f"step_{60:012d}"]
    (run / "checkpoints" / ".staging-left-by-a-kill").mkdir()  # as a kill while saving leaves it
    (run / ".staging-left-by-a-kill").mkdir()
    result = train(run, resume=True, total_steps=200, asynchronous=False, say=lambda message: None)
    assert result.resumed_from == 60 and not list(run.rglob(".staging-*"))
    rows = episode_rows(run)
    assert len(rows) == sum(json.loads((run / "final" / "state.json").read_text())["curriculum"]["episodes"])


def test_a_full_disk_while_logging_episodes_names_the_log(tmp_path, monkeypatch):
    from aaai import files

    monkeypatch.setattr(files.os, "pwrite", no_space)
    run = tmp_path / "run"
    result = CliRunner().invoke(
        cli,
        ["train", "--agent", "random", "--steps", "1000", "--config", str(tiny_config(tmp_path)), "--run", str(run)],
    )
    assert result.exit_code == 1 and len(result.output.strip().splitlines()) == 1, result.output
    assert f"cannot write {str(run / 'episodes.csv')!r}: No space left on device" in result.output
    assert (run / "episodes.csv").read_text() == ""  # no torn row left: the failed write is cut back


@pytest.mark.parametrize(
    "failure",
    [
        lambda path: no_space(),
        lambda path: (_ for _ in ()).throw(PermissionError(errno.EACCES, "Permission denied", str(path))),
    ],
    ids=["ENOSPC", "EACCES"],
)
def test_a_model_that_cannot_be_saved_leaves_no_staging_folder_and_is_named(tmp_path, failure):
    run = RunFolder(tmp_path / "run")
    with pytest.raises(OSError) as raised:
        run.save_checkpoint(40, {"curriculum": {}}, save_model=failure)
    assert raised.value.filename == str(run.checkpoints / f"step_{40:012d}" / "model.zip")
    assert list(run.checkpoints.iterdir()) == []  # neither the checkpoint nor its staging folder


@pytest.mark.long  # needs the right to mount (root in CI's container); about 20 s
def test_training_on_a_real_full_disk_stops_in_one_line_and_resumes_once_space_is_freed(tmp_path):
    import shutil
    import subprocess
    import sys

    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(disk)], capture_output=True).returncode:
        pytest.skip("cannot mount a small filesystem here")
    try:
        run = disk / "run"
        config = tiny_config(tmp_path)
        config.write_text(config.read_text().replace("checkpoint_every: 60", "checkpoint_every: 200"))
        full = subprocess.run(
            [sys.executable, "-m", "aaai_cli.main", "train", "--agent", "random", "--steps", "100000000"]
            + ["--config", str(config), "--run", str(run)],
            capture_output=True,
            text=True,
            timeout=600,
        )
        lines = full.stderr.strip().splitlines()
        assert full.returncode == 1 and len(lines) == 1, full.stderr[-3000:]
        assert re.search(rf"cannot write '{re.escape(str(run))}/[^']+': No space left on device", lines[0]), lines[0]
        assert not list(run.rglob(".staging-*")) and not (run / ".lock").exists()
        points = sorted((run / "checkpoints").iterdir())
        for point in points[:-1]:  # space freed: the older checkpoints go
            shutil.rmtree(point)
        last = step_of(points[-1])
        train(run, resume=True, total_steps=last + 200, asynchronous=False, say=lambda message: None)
        rows = episode_rows(run)
        assert len(rows) == sum(json.loads((run / "final" / "state.json").read_text())["curriculum"]["episodes"])
        assert [int(row[0]) for row in rows] == sorted(int(row[0]) for row in rows)
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)
