"""SIGKILL at seeded random moments, from outside, as `kill -9` or the OOM killer would (and at known
points, from inside): then the same command again (or `--resume`), and what survives is checked.

- `aaai train` (stable-baselines3 PPO, and RLlib PPO on Ray): killed some time after its first
  checkpoint, it resumes from its newest whole checkpoint with that checkpoint's curriculum
  state, and the episode log has every episode once: none duplicated, none from after the
  checkpoint (orphaned), no torn row. Killed before its first checkpoint, it starts again from
  step 0 with its log emptied to its header; killed while writing a checkpoint, the half-written
  folder is removed.
- `aaai eval --backend ray`: the driver killed after some rows, then run again, gives the
  scoreboard of an uninterrupted local run, row for row; no Ray process outlives it.
"""

from __future__ import annotations

import csv
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml
from conftest import processes_holding

AAAI = [sys.executable, "-m", "aaai_cli.main"]


def _kill_when(process: subprocess.Popen, ready, delay: float, timeout: float = 300) -> bool:
    """Waits until ``ready()`` (or the process ends), then ``delay`` seconds more, then SIGKILLs the
    process alone (its children are left to notice, as after a real kill). True if it was killed."""
    deadline = time.monotonic() + timeout
    while process.poll() is None and not ready():
        assert time.monotonic() < deadline, "the process never reached the moment to kill it"
        time.sleep(0.02)
    time.sleep(delay)
    if process.poll() is not None:
        return False
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    return True


def _reap_group(process: subprocess.Popen) -> None:
    """After the test: the killed command's own process group (workers it started) is ended."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _checkpoints(run: Path) -> list[Path]:
    folder = run / "checkpoints"
    return sorted(folder.glob("step_*")) if folder.is_dir() else []


def _whole_checkpoints(run: Path) -> list[Path]:
    return [point for point in _checkpoints(run) if (point / "state.json").is_file()]


def _episode_rows(run: Path) -> list[dict]:
    with open(run / "episodes.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def _check_resumed(run: Path, last: dict, target: int) -> None:
    """The run finished at ``target`` from checkpoint ``last`` (its state.json), and its episode log
    holds every episode once."""
    final = json.loads((run / "final" / "state.json").read_text())
    assert final["step"] == target
    saved, resumed = last["curriculum"]["episodes"], final["curriculum"]["episodes"]
    assert all(after >= before for before, after in zip(saved, resumed)) and sum(resumed) > sum(saved)
    rows = _episode_rows(run)
    assert all(None not in row and all(value not in (None, "") for value in row.values()) for row in rows), (
        "a torn row in the episode log"
    )
    steps = [int(row["step"]) for row in rows]
    assert steps == sorted(steps), "episodes out of order: rows from after the checkpoint were kept"
    assert len(rows) == sum(resumed), "the episode log does not match the curriculum's count"
    assert len({tuple(row.items()) for row in rows}) == len(rows), "a duplicated episode row"
    assert sum(step <= last["step"] for step in steps) == sum(saved), (
        "the episodes up to the checkpoint are not exactly those the checkpoint counted"
    )


def _train_config(tmp_path: Path) -> Path:
    config = {
        "episode": {"max_steps": 60},
        "curriculum": {"levels": "0-1", "difficulties": "0-1"},
        "train": {
            "checkpoint_every": 256,
            "heatmap_every": 100000,
            "n_steps": 64,
            "batch_size": 64,
            "n_epochs": 1,
            "net_width": 16,
        },
    }
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def _kill_train_and_resume(
    tmp_path: Path, seed: int, extra: list[str], env: dict | None = None, resume_steps: int = 512
) -> None:
    rng = random.Random(seed)
    run = tmp_path / "run"
    command = [
        *AAAI,
        "train",
        "--agent",
        "ppo",
        "--envs",
        "2",
        "--steps",
        "10000000",
        "--config",
        str(_train_config(tmp_path)),
        "--run",
        str(run),
        *extra,
    ]
    with open(tmp_path / "stderr.txt", "w") as stderr:  # a file: orphaned workers may hold a pipe open
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr, env=env, start_new_session=True)
    try:
        killed = _kill_when(process, lambda: bool(_whole_checkpoints(run)), rng.uniform(0.0, 3.0))
    finally:
        _reap_group(process)
    assert killed, (tmp_path / "stderr.txt").read_text()[-3000:]
    assert not (run / "final").exists()
    last = json.loads((_whole_checkpoints(run)[-1] / "state.json").read_text())
    target = last["step"] + resume_steps
    resumed = subprocess.run(
        [*AAAI, "train", "--resume", str(run), "--steps", str(target)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert resumed.returncode == 0, (resumed.stdout + resumed.stderr)[-3000:]
    _check_resumed(run, last, target)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.long), pytest.param(2, marks=pytest.mark.long)])
def test_sb3_training_killed_at_a_random_moment_resumes_from_its_checkpoint(tmp_path, seed):
    pytest.importorskip("stable_baselines3", reason="needs the train extra, which make test installs")
    _kill_train_and_resume(tmp_path, seed, [])


@pytest.fixture
def ray_env():
    pytest.importorskip("ray", reason="needs the ray extra, which make test installs")
    ray_tmp = tempfile.mkdtemp(prefix="aaaikill", dir="/tmp")  # short: Ray's socket paths live here
    yield {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_TMPDIR": ray_tmp}
    deadline = time.time() + 30
    while (left := processes_holding(ray_tmp)) and time.time() < deadline:
        time.sleep(0.5)
    for pid in left:  # this test's own Ray processes, found by their private temp folder
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    shutil.rmtree(ray_tmp, ignore_errors=True)
    assert not left, f"Ray processes outlived the killed command by 30 s: {sorted(left)}"


@pytest.mark.long  # about a minute or more: Ray and RLlib start twice. The simulated kill (newer checkpoints
# taken away, then --resume) is in make test: tests/test_rllib.py::test_rllib_run_writes_its_folder_and_resumes
@pytest.mark.parametrize("seed", [0, 1])
def test_rllib_training_killed_at_a_random_moment_resumes_from_its_checkpoint(tmp_path, seed, ray_env):
    pytest.importorskip("ray.rllib", reason="needs the ray extra, which make test installs")
    _kill_train_and_resume(tmp_path, seed, ["--backend", "rllib"], env=ray_env, resume_steps=1024)


def _table(path: Path) -> list[list[str]]:
    """A scoreboard's rows without the timing column (header included)."""
    with open(path, newline="") as handle:
        return [row[:-1] for row in csv.reader(handle)]


# long: about 45 s a seed (Ray starts twice); test_ray_eval's resume test covers a rerun in make test
@pytest.mark.long
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ray_eval_driver_killed_at_a_random_moment_then_rerun_equals_an_uninterrupted_run(tmp_path, seed, ray_env):
    rng = random.Random(seed)
    config = tmp_path / "short.yaml"
    config.write_text(yaml.safe_dump({"episode": {"max_steps": 40}}))
    command = [
        *AAAI,
        "eval",
        "--policy",
        "random",
        "--levels",
        "0",
        "--difficulty",
        "0-1",
        "-k",
        "5",
        "--config",
        str(config),
    ]
    whole, killed = tmp_path / "whole.csv", tmp_path / "killed.csv"
    subprocess.run([*command, "--out", str(whole)], check=True, capture_output=True, timeout=300)
    rows_before_kill = rng.randint(0, 6)

    def enough_rows() -> bool:
        return killed.exists() and len(killed.read_text().splitlines()) - 1 >= rows_before_kill

    process = subprocess.Popen(
        [*command, "--backend", "ray", "--workers", "2", "--out", str(killed)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=ray_env,
        start_new_session=True,
    )
    try:
        _kill_when(process, enough_rows, rng.uniform(0.0, 0.3))
    finally:
        _reap_group(process)
    again = subprocess.run(
        [*command, "--backend", "ray", "--workers", "2", "--out", str(killed)],
        capture_output=True,
        text=True,
        env=ray_env,
        timeout=300,
    )
    assert again.returncode == 0, again.stderr[-3000:]
    assert _table(killed) == _table(whole)


# `aaai train --agent random` that SIGKILLs itself at a known point (its first argument), as `kill -9`
# or the OOM killer would there: no clean-up, no finally blocks.
KILLED_AT = """
import os, signal, sys
import aaai.scoring.runs as runs
from aaai_cli.main import cli

point, replace, calls = sys.argv[1], os.replace, {"replace": 0}
create, log_episodes = runs.RunFolder.create, runs.RunFolder.log_episodes

def die():
    os.kill(os.getpid(), signal.SIGKILL)

def create_then_die(self, config):  # config.yaml written, no episode yet
    create(self, config)
    if point == "created":
        die()

def log_then_die(self, step, episodes):  # the first rows logged; the first checkpoint is far off
    log_episodes(self, step, episodes)
    if point == "first-rows" or (point == "after-checkpoint" and (self.path / "checkpoints").is_dir()):
        die()

def replace_or_die(source, target, *args, **kwargs):  # the second checkpoint written, not yet renamed
    if os.path.basename(source).startswith(runs.STAGING_PREFIX):
        calls["replace"] += 1
        if point == "staging" and calls["replace"] == 2:
            die()
    return replace(source, target, *args, **kwargs)

runs.RunFolder.create, runs.RunFolder.log_episodes, runs.os.replace = create_then_die, log_then_die, replace_or_die
cli(sys.argv[2:], prog_name="aaai")
"""


@pytest.mark.parametrize(
    "point",
    [
        "first-rows",  # about 2 s each; the others in make test-long (a staging folder's removal: test_resume.py)
        pytest.param("staging", marks=pytest.mark.long),
        pytest.param("created", marks=pytest.mark.long),
        pytest.param("after-checkpoint", marks=pytest.mark.long),
    ],
)
def test_training_killed_at_each_point_resumes_with_one_log_row_per_counted_episode(tmp_path, point):
    """Killed before its first row, after its first rows (before any checkpoint), while writing a
    checkpoint, after one: --resume continues from the newest whole checkpoint (or from step 0, its
    episode log emptied to its header), and the log ends with exactly the episodes the run counted."""
    from aaai.train.training import train

    run = tmp_path / "run"
    config = tmp_path / "tiny.yaml"
    every = 10**6 if point in ("created", "first-rows") else 60
    config.write_text(
        yaml.safe_dump(
            {
                "episode": {"max_steps": 20},
                "curriculum": {"levels": "0", "difficulties": "0"},
                "train": {"checkpoint_every": every, "heatmap_every": 10**6, "num_envs": 1, "vector": "sync"},
            }
        )
    )
    killed = subprocess.run(
        [sys.executable, "-c", KILLED_AT, point, "train", "--agent", "random", "--steps", "10000000"]
        + ["--config", str(config), "--run", str(run)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr[-3000:]
    if point == "staging":
        assert list((run / "checkpoints").glob(".staging-*")), "killed before its second checkpoint was whole"
    before = RunFolderView(run)
    train(run, resume=True, total_steps=before.step + 100, asynchronous=False, say=lambda message: None)
    assert not list(run.rglob(".staging-*")) and not (run / ".lock").exists()
    final = json.loads((run / "final" / "state.json").read_text())
    assert final["step"] == before.step + 100
    text = (run / "episodes.csv").read_text()
    assert text.count("step,worker") == 1
    rows = _episode_rows(run)
    steps = [int(row["step"]) for row in rows]
    assert steps == sorted(steps), "episodes out of order: rows from before the resumed point were kept"
    assert len(rows) == sum(final["curriculum"]["episodes"]) > 0, "the episode log does not match the count"
    assert sum(step <= before.step for step in steps) == before.counted


class RunFolderView:
    """What a killed run left: the step and episode count of its newest whole checkpoint (0 without one)."""

    def __init__(self, run: Path):
        points = _whole_checkpoints(run)
        state = json.loads((points[-1] / "state.json").read_text()) if points else None
        self.step = state["step"] if state else 0
        self.counted = sum(state["curriculum"]["episodes"]) if state else 0
