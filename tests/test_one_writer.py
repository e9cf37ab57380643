"""One process at a time writes a run folder or a scoreboard: a second `aaai train --run X`, `aaai
train --resume X` or `aaai eval --out F` on the same target refuses at once, in one line naming the
holder's pid and the target; the holder's kill frees it (the operating system releases the lock)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from aaai.config import load_config
from aaai.scoring.evaluation import cells_for, evaluate, policy_record
from aaai.train.training import train
from aaai_cli.main import cli

AAAI = [sys.executable, "-m", "aaai_cli.main"]


def tiny_config(tmp_path: Path, checkpoint_every: int = 10**6) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "episode": {"max_steps": 20},
                "curriculum": {"levels": "0", "difficulties": "0"},
                "train": {
                    "checkpoint_every": checkpoint_every,
                    "heatmap_every": 10**6,
                    "num_envs": 1,
                    "vector": "sync",
                },
            }
        )
    )
    return path


def wait_for_holder(lock: Path, process: subprocess.Popen, ready=lambda: True, timeout: float = 120) -> None:
    """Until ``process`` holds the lock file ``lock`` (its pid written in it) and ``ready()``."""
    deadline = time.monotonic() + timeout
    while True:
        assert process.poll() is None, f"the holder ended ({process.returncode})"
        assert time.monotonic() < deadline, "the holder never took its lock"
        try:
            if lock.read_text() == f"{process.pid}\n" and ready():
                return
        except FileNotFoundError:
            pass
        time.sleep(0.02)


def refused(args: list[str], pid: int, target: Path) -> None:
    """The command, run while process ``pid`` holds ``target``, refuses at once in one line naming both."""
    started = time.monotonic()
    result = CliRunner().invoke(cli, [str(arg) for arg in args])
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1 and len(lines) == 1, result.output
    assert f"process {pid}" in lines[0] and repr(str(target)) in lines[0], lines[0]
    assert time.monotonic() - started < 2.0, "not refused at once"


def counted_rows(run: Path) -> tuple[list[dict], int]:
    with open(run / "episodes.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    return rows, sum(json.loads((run / "final" / "state.json").read_text())["curriculum"]["episodes"])


class Holder(threading.Thread):
    """``work(pause)`` in a thread of this process; ``pause()``, called from the work, stops it there
    (its lock held) until the test lets it go on."""

    def __init__(self, work):
        super().__init__(daemon=True)
        self.work, self.paused, self.go, self.error = work, threading.Event(), threading.Event(), None

    def pause(self, *args) -> None:
        if not self.paused.is_set():
            self.paused.set()
            self.go.wait(timeout=120)

    def run(self) -> None:
        try:
            self.work(self.pause)
        except BaseException as error:  # reported by finish()
            self.error = error

    def __enter__(self) -> "Holder":
        self.start()
        assert self.paused.wait(timeout=120), self.error
        return self

    def __exit__(self, *exc) -> None:
        self.go.set()
        self.join(timeout=120)
        assert self.error is None, self.error


def test_a_run_in_training_refuses_a_second_train_and_resume_naming_the_holder(tmp_path):
    run = tmp_path / "run"
    config = tiny_config(tmp_path)
    settings = load_config(str(config), agent="random", total_steps=100)
    with Holder(
        lambda pause: train(run, settings, asynchronous=False, on_episodes=pause)
    ):  # paused after its first rows
        refused(["train", "--agent", "random", "--config", config, "--run", run], os.getpid(), run)
        refused(["train", "--resume", run, "--steps", 1000], os.getpid(), run)
    rows, counted = counted_rows(run)  # the holder went on alone: no second header, one row per episode
    assert (run / "episodes.csv").read_text().count("step,worker") == 1 and len(rows) == counted > 0
    assert not (run / ".lock").exists()


def test_a_scoreboard_being_written_refuses_a_second_eval_naming_the_holder(tmp_path):
    board, config = tmp_path / "board.csv", tmp_path / "short.yaml"
    config.write_text(yaml.safe_dump({"episode": {"max_steps": 20}}))
    command = ["eval", "--policy", "random", "--levels", "0", "--difficulty", "0", "--config", str(config)]
    # imported by every eval before its work: not counted in "at once" below
    pytest.importorskip("torch", reason="needs the train extra (torch)")
    settings = load_config(str(config))
    cells = cells_for([0], [0], "reserved", 2)
    record = policy_record("random", "reserved")
    with Holder(lambda pause: evaluate("random", cells, board, settings, on_episode=pause, record=record)):
        refused([*command, "-k", "3", "--out", board], os.getpid(), board)
    assert len(board.read_text().splitlines()) == 3  # the holder's header and two rows alone
    again = CliRunner().invoke(cli, [*command, "-k", "3", "--out", str(board)])  # free: it continues the scoreboard
    assert again.exit_code == 0, again.output
    assert board.read_text().count("level,level_name") == 1 and len(board.read_text().splitlines()) == 4
    assert not (tmp_path / ".board.csv.lock").exists()


@pytest.mark.long  # a real `aaai train` holds the run: about 3 s
def test_a_run_held_by_another_process_is_refused_and_free_once_it_is_killed(tmp_path):
    run, config = tmp_path / "run", tiny_config(tmp_path)
    with open(tmp_path / "stderr.txt", "w") as stderr:
        holder = subprocess.Popen(
            [*AAAI, "train", "--agent", "random", "--steps", "100000000", "--config", str(config), "--run", str(run)],
            stdout=subprocess.DEVNULL,
            stderr=stderr,
        )
    try:
        wait_for_holder(run / ".lock", holder, ready=lambda: (run / "episodes.csv").is_file())
        refused(["train", "--agent", "random", "--config", config, "--run", run], holder.pid, run)
        refused(["train", "--resume", run, "--steps", 1000], holder.pid, run)
        assert holder.poll() is None  # the holder trains on
    finally:
        holder.kill()
        holder.wait()
    assert (run / "episodes.csv").read_text().count("step,worker") == 1
    train(run, resume=True, total_steps=60, asynchronous=False, say=lambda message: None)  # no stale lock
    rows, counted = counted_rows(run)
    assert len(rows) == counted > 0


@pytest.mark.long  # a real `aaai eval` holds the scoreboard: about 8 s (torch's import)
def test_a_scoreboard_held_by_another_process_is_refused_and_free_once_it_is_killed(tmp_path):
    board, config = tmp_path / "board.csv", tmp_path / "short.yaml"
    config.write_text(yaml.safe_dump({"episode": {"max_steps": 20}}))
    command = ["eval", "--policy", "random", "--levels", "0", "--difficulty", "0", "--config", str(config)]
    pytest.importorskip("torch", reason="needs the train extra (torch)")
    holder = subprocess.Popen(
        [*AAAI, *command, "-k", "1000", "--out", str(board)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        wait_for_holder(tmp_path / ".board.csv.lock", holder, ready=lambda: board.is_file())
        refused([*command, "-k", "2", "--out", board], holder.pid, board)
        assert holder.poll() is None
    finally:
        holder.kill()
        holder.wait()
    again = CliRunner().invoke(cli, [*command, "-k", "2", "--out", str(board)])  # no stale lock: it continues
    assert again.exit_code == 0, again.output
    assert board.read_text().count("level,level_name") == 1


@pytest.mark.long  # two processes started at once, twice: about 6 s on 2 busy cores
@pytest.mark.parametrize("resume", [False, True])
def test_two_trains_of_one_run_started_at_once_never_both_proceed(tmp_path, resume):
    run, config = tmp_path / "run", tiny_config(tmp_path, checkpoint_every=100)
    if resume:  # a run of 200 steps, resumed to 600 by both
        train(run, load_config(str(config), agent="random", total_steps=200), asynchronous=False)
        args = ["train", "--resume", str(run), "--steps", "600"]
    else:
        args = ["train", "--agent", "random", "--steps", "600", "--config", str(config), "--run", str(run)]
    both = [subprocess.Popen([*AAAI, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in "ab"]
    results = [(process, *process.communicate(timeout=300)) for process in both]
    (winner, _, _), (loser, _, error) = sorted(results, key=lambda result: result[0].returncode)
    assert winner.returncode == 0 and loser.returncode != 0, "both proceeded"
    if loser.returncode == 1:  # it came while the other trained: refused, naming it
        assert f"process {winner.pid}" in error, error
    else:  # it came after the other had finished: refused as a run already started or done
        assert loser.returncode == 2 and ("already holds a run" in error or "already has 600 steps" in error), error
    rows, counted = counted_rows(run)
    assert (run / "episodes.csv").read_text().count("step,worker") == 1 and len(rows) == counted
