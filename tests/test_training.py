"""`aaai train` and `aaai eval` as a user runs them: the CLI in subprocesses where a process of its own
matters (a kill, a resume, determinism across processes, what a pipe shows), in this process otherwise."""

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from conftest import aaai, aaai_here

from aaai.scoring.evaluation import COLUMNS
from aaai_cli.main import cli


def small_config(tmp_path, **train):
    config = {
        "episode": {"max_steps": 100},
        "curriculum": {"levels": "0-1", "difficulties": "0-1"},
        "train": {
            "num_envs": 2,
            "checkpoint_every": 400,
            "heatmap_every": 200,
            "n_steps": 64,
            "batch_size": 64,
            "n_epochs": 2,
            "net_width": 32,
            **train,
        },
    }
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def read_state(folder: Path) -> dict:
    return json.loads((folder / "state.json").read_text())


def test_random_agent_run_writes_its_folder(tmp_path):
    run = tmp_path / "run"
    aaai("train", "--random", "--agent", "random", "--steps", 1000, "--config", small_config(tmp_path), "--run", run)
    assert (run / "config.yaml").is_file() and (run / "versions.json").is_file()
    sensors = yaml.safe_load((run / "config.yaml").read_text())["sensors"]
    assert sensors["joint_velocities"] and sensors["head_orientation"] and sensors["foot_contacts"]
    assert (run / "curriculum.png").is_file()
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == [f"step_{s:012d}" for s in (400, 800)]
    state = read_state(run / "final")
    assert state["step"] == 1000 and state["curriculum"]["mode"] == "random"
    with open(run / "episodes.csv") as handle:
        episodes = list(csv.DictReader(handle))
    assert len(episodes) == sum(state["curriculum"]["episodes"]) >= 8  # 100-step episodes, 2 workers
    assert {(int(e["level"]), int(e["difficulty"])) for e in episodes} <= {(0, 0), (0, 1), (1, 0), (1, 1)}
    again = aaai("train", "--agent", "random", "--run", run, check=False)
    assert again.returncode != 0 and "already holds a run" in again.stderr


# `aaai train` whose process kills itself (SIGKILL: no clean-up, as `kill -9` or the OOM killer) right
# after the training loop has passed step KILL_AT: a kill at a known point, not at a moment of the clock.
KILL_AT = 1400
KILLED_TRAIN = f"""
import os, signal, sys
import aaai.train.training
from aaai_cli.main import cli

update = aaai.train.training.Tracker.update

def update_then_die(self, step, *args, **kwargs):
    update(self, step, *args, **kwargs)  # episodes logged, heatmap and checkpoint written as due
    if step >= {KILL_AT}:
        os.kill(os.getpid(), signal.SIGKILL)

aaai.train.training.Tracker.update = update_then_die
cli(sys.argv[1:], prog_name="aaai")
"""


def test_resume_after_a_kill_continues_curriculum_and_step_count(tmp_path):
    run = tmp_path / "run"
    with open(tmp_path / "stderr.txt", "w") as stderr:  # a file: orphaned workers may hold a pipe open
        process = subprocess.Popen(
            [
                sys.executable,
                "-c",
                KILLED_TRAIN,
                "train",
                "--agent",
                "random",
                "--steps",
                "10000000",
                "--config",
                str(small_config(tmp_path)),
                "--run",
                str(run),
            ],
            stdout=subprocess.DEVNULL,
            stderr=stderr,
        )
        process.wait(timeout=600)  # only a guard against a hang; it dies at step KILL_AT
    assert process.returncode == -signal.SIGKILL, (tmp_path / "stderr.txt").read_text()
    assert not (run / "final").exists()  # killed: the run never finished
    assert [p.name for p in sorted((run / "checkpoints").glob("step_*"))] == [
        f"step_{s:012d}" for s in (400, 800, 1200)
    ]  # checkpoint_every 400, killed at 1400
    with open(run / "episodes.csv") as handle:
        assert max(int(row["step"]) for row in csv.DictReader(handle)) > 1200  # logged after the last checkpoint
    checkpoints = sorted((run / "checkpoints").iterdir())
    last = read_state(checkpoints[-1])
    aaai("train", "--resume", run, "--steps", last["step"] + 600)
    final = read_state(run / "final")
    assert final["step"] == last["step"] + 600
    saved, resumed = last["curriculum"], final["curriculum"]
    assert sum(resumed["episodes"]) > sum(saved["episodes"])
    assert all(after >= before for before, after in zip(saved["episodes"], resumed["episodes"]))
    with open(run / "episodes.csv") as handle:
        steps = [int(row["step"]) for row in csv.DictReader(handle)]
    assert steps == sorted(steps)  # episodes logged after the checkpoint, then lost, were dropped
    assert len(steps) == sum(resumed["episodes"])


def test_eval_scoreboard_schema_determinism_and_skipping(tmp_path):
    out = tmp_path / "board.csv"
    args = [
        "eval",
        "--seeds",
        "reserved",
        "--policy",
        "random",
        "--levels",
        "0-1",
        "--difficulty",
        "0",
        "-k",
        2,
        "--config",
        small_config(tmp_path),
    ]
    result = aaai(*args, "--out", out)
    assert "| overall | 4 |" in result.stdout
    with open(out) as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0].keys()) == COLUMNS and len(rows) == 4
    for row in rows:
        ratio = float(row["return"]) / float(row["max_reward"])
        assert float(row["ratio"]) == pytest.approx(ratio, abs=1e-5)
        assert row["outcome"] == ("succeeded" if ratio >= 1 else "passed" if ratio >= 0.8 else "failed")
        assert 1288490240 <= int(row["seed"]) < 1717986944
    assert (tmp_path / "board_summary.md").is_file()

    def without_time(path):
        with open(path) as handle:
            return [{k: v for k, v in row.items() if k != "wall_seconds"} for row in csv.DictReader(handle)]

    second = tmp_path / "second.csv"
    aaai(*args, "--out", second)
    assert without_time(second) == without_time(out)
    # An interrupted eval: two rows and a torn third line; re-running scores only what is missing.
    lines = out.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:3]) + lines[3][:10])
    aaai_here(*args, "--out", out)
    assert without_time(out) == without_time(second)


def test_train_with_ppo_then_eval_end_to_end(tmp_path):
    run = tmp_path / "ppo"
    aaai("train", "--curriculum", "--steps", 512, "--config", small_config(tmp_path), "--run", run)
    assert (run / "final" / "model.zip").is_file() and (run / "tb").is_dir()
    assert read_state(run / "final")["step"] >= 512  # 4 updates of 2 x 64 steps
    aaai_here("eval", "--seeds", "reserved", "--policy", run, "-k", 1, "--difficulty", 0)
    with open(run / "scoreboard_reserved.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["level"], r["difficulty"]) for r in rows] == [("0", "0"), ("1", "0")]
    first = [r["return"] for r in rows]
    (run / "scoreboard_reserved.csv").unlink()
    aaai_here("eval", "--seeds", "reserved", "--policy", run, "-k", 1, "--difficulty", 0)
    with open(run / "scoreboard_reserved.csv") as handle:
        assert [r["return"] for r in csv.DictReader(handle)] == first  # deterministic policy, same seeds


def test_cli_errors_are_clear(tmp_path):
    result = aaai("train", "--difficulty", "11", "--run", tmp_path / "x", check=False)
    assert result.returncode != 0 and "--difficulty: got '11'" in result.stderr and "0 to 10" in result.stderr
    result = aaai_here("train", "--levels", "0-14", "--run", tmp_path / "x", check=False)
    assert (
        result.returncode != 0
        and "--levels" in result.stderr
        and "got '0-14'" in result.stderr
        and "0 to 12" in result.stderr
    )
    result = aaai_here("eval", "--policy", "nope.zip", check=False)
    assert result.returncode != 0 and "nope.zip" in result.stderr
    result = aaai_here("eval", "--seeds", "a,b", check=False)
    assert result.returncode != 0 and "--seeds" in result.stderr


def test_eval_scores_the_task_reward_even_when_the_config_shapes_it(tmp_path):
    shaped = tmp_path / "shaped.yaml"
    shaped.write_text(yaml.safe_dump({"episode": {"max_steps": 100, "shaping": 5.0}}))
    plain = tmp_path / "plain.yaml"
    plain.write_text(yaml.safe_dump({"episode": {"max_steps": 100}}))
    boards = []
    for name, config in (("shaped", shaped), ("plain", plain)):
        out = tmp_path / f"{name}.csv"
        aaai_here(
            "eval", "--policy", "random", "--levels", 0, "--difficulty", 0, "-k", 2, "--config", config, "--out", out
        )
        with open(out) as handle:
            boards.append([row["return"] for row in csv.DictReader(handle)])
    assert boards[0] == boards[1]


def test_eval_on_training_seeds_and_on_a_seed_list(tmp_path):
    config = small_config(tmp_path)
    listed, train = tmp_path / "listed.csv", tmp_path / "train.csv"
    aaai_here("eval", "--seeds", "5,6", "--levels", 0, "--difficulty", 0, "--config", config, "--out", listed)
    aaai_here("eval", "--seeds", "train", "-k", 2, "--levels", 0, "--difficulty", 0, "--config", config, "--out", train)
    with open(listed) as handle:
        assert [int(row["seed"]) for row in csv.DictReader(handle)] == [5, 6]
    with open(train) as handle:
        seeds = [int(row["seed"]) for row in csv.DictReader(handle)]
    assert len(seeds) == 2 and all(0 <= s < 1288490240 for s in seeds)


def test_a_secret_seed_key_gives_a_hidden_reproducible_list_and_is_recorded_not_revealed(tmp_path, monkeypatch):
    from aaai.levels.seeds import RESERVED_SEEDS, reserved_seeds

    key_file = tmp_path / "key.txt"
    key_file.write_text("a secret only the organisers hold\n")
    public = CliRunner().invoke(cli, ["seeds", "--levels", "0", "--difficulty", "0", "-k", "3"])
    hidden = CliRunner().invoke(
        cli, ["seeds", "--levels", "0", "--difficulty", "0", "-k", "3", "--seed-key-file", str(key_file)]
    )
    monkeypatch.setenv("AAAI_SEED_KEY", "a secret only the organisers hold")
    from_variable = CliRunner().invoke(cli, ["seeds", "--levels", "0", "--difficulty", "0", "-k", "3"])
    assert public.exit_code == hidden.exit_code == from_variable.exit_code == 0
    assert hidden.output == from_variable.output != public.output
    seeds = [int(s) for s in hidden.output.splitlines()[-1].split(": ")[1].split(",")]
    assert all(seed in RESERVED_SEEDS for seed in seeds) and seeds != reserved_seeds(0, 0, 3)

    out = tmp_path / "hidden.csv"
    scored = CliRunner().invoke(
        cli, ["eval", "--policy", "random", "--levels", "0", "--difficulty", "0", "-k", "3", "--out", str(out)]
    )
    assert scored.exit_code == 0, scored.output
    with open(out) as handle:
        assert sorted(int(row["seed"]) for row in csv.DictReader(handle)) == sorted(seeds)
    record = (tmp_path / "hidden_scored_with.json").read_text()
    assert '"seed_key": "sha256:' in record and "organisers" not in record
    assert "organisers" not in out.read_text()


def test_a_scoreboard_refuses_episodes_of_another_policy(tmp_path):
    out = tmp_path / "board.csv"
    args = ["eval", "--levels", "0", "--difficulty", "0", "-k", "1", "--out", str(out)]
    first = CliRunner().invoke(cli, args + ["--policy", "random"])
    assert first.exit_code == 0, first.output
    before = out.read_text()
    other = CliRunner().invoke(cli, args + ["-k", "2", "--policy", "reference"])
    assert other.exit_code == 2 and "refusing to add episodes" in other.output and "'reference'" in other.output
    assert out.read_text() == before
    resumed = CliRunner().invoke(cli, args + ["-k", "2", "--policy", "random"])  # the same policy resumes
    assert resumed.exit_code == 0 and len(out.read_text().splitlines()) == 3


@pytest.mark.parametrize(
    "extra", [["--levels", "5-7"], ["--camera"], ["--random"], ["--envs", "4"], ["--minutes", "5"]]
)
def test_resume_refuses_options_it_cannot_honour(tmp_path, extra):
    run = tmp_path / "run"
    started = CliRunner().invoke(
        cli, ["train", "--agent", "random", "--steps", "100", "--envs", "1", "--run", str(run)]
    )
    assert started.exit_code == 0, started.output
    before = (run / "config.yaml").read_text()
    resumed = CliRunner().invoke(cli, ["train", "--resume", str(run), "--steps", "200", *extra])
    assert resumed.exit_code == 2 and extra[0] in resumed.output and "cannot change on resume" in resumed.output
    assert (run / "config.yaml").read_text() == before


def test_outputs_that_cannot_be_written_are_refused_before_any_work(tmp_path, monkeypatch):
    folder = tmp_path / "a_folder"
    folder.mkdir()
    into_folder = CliRunner().invoke(
        cli, ["eval", "--policy", "random", "--levels", "0", "--difficulty", "0", "-k", "1", "--out", str(folder)]
    )
    assert into_folder.exit_code == 2 and "which is a folder" in into_folder.output
    locked = tmp_path / "locked"
    locked.mkdir()
    # a folder without write permission (as root, which writes anywhere, the permission is denied here)
    real_access = os.access
    monkeypatch.setattr(
        "aaai.scoring.runs.os.access",
        lambda path, mode: False if str(path).startswith(str(locked)) else real_access(path, mode),
    )
    result = CliRunner().invoke(
        cli,
        [
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "--difficulty",
            "0",
            "-k",
            "1",
            "--out",
            str(locked / "board.csv"),
        ],
    )
    assert result.exit_code == 2 and "cannot be written to" in result.output
    run = CliRunner().invoke(cli, ["train", "--agent", "random", "--steps", "50", "--run", str(locked / "run")])
    assert run.exit_code == 2 and "cannot be written to" in run.output
    assert list(locked.iterdir()) == []  # nothing was started


# --- progress, TensorBoard, plots, the curricula experiment -----------------------------------
PROGRESS_LINE = (
    r"training(?: \([^)]*\))?: (\d+) / 3000 steps \(\d+%\), (\d+|-) steps/s, (\d+) episodes, "
    r"pass rate (-|\d+% of the last \d+), ETA "
)


def test_progress_rate_and_eta_leave_out_the_startup():
    from aaai.train.training import Progress

    now, lines = [0.0], []
    report = Progress(100_000, clock=lambda: now[0], every=10.0, write=lines.append)
    now[0] = 600.0  # ten minutes of start-up (workers, torch) before the first step
    report.update(100)
    assert report.eta() is None and "ETA -" in report.line()  # one update: no rate yet
    for _ in range(10):  # then 1000 steps/s
        now[0] += 1.0
        report.update(1000)
    assert report.rate() == pytest.approx(1000.0)
    assert report.eta() == pytest.approx((100_000 - 10_100) / 1000.0)  # 90 s, not hours
    assert "ETA 1 min 30 s" in report.line()
    assert len(lines) == 2 and "100 / 100000 steps" in lines[0] and "10100 / 100000 steps" in lines[1]  # every 10 s
    report.add_episodes([True, False, False, False])
    assert "4 episodes, pass rate 25% of the last 4" in report.line()


def test_a_non_terminal_train_and_eval_print_progress_lines(tmp_path):
    import re

    run = tmp_path / "run"
    result = aaai(
        "train",
        "--agent",
        "random",
        "--steps",
        3000,
        "--progress-every",
        0.1,
        "--config",
        small_config(tmp_path),
        "--run",
        run,
    )  # stdout is a pipe
    lines = [line for line in result.stdout.splitlines() if line.startswith("training")]
    assert len(lines) >= 3, result.stdout
    parsed = [re.match(PROGRESS_LINE, line) for line in lines]
    assert all(parsed), lines
    steps = [int(m.group(1)) for m in parsed]
    assert steps == sorted(steps) and steps[-1] == 3000
    assert int(parsed[-1].group(3)) >= 20 and parsed[-1].group(4) != "-"  # 100-step episodes were counted
    board = tmp_path / "board.csv"
    scored = aaai_here(
        "eval",
        "--policy",
        "random",
        "--levels",
        0,
        "--difficulty",
        "0-1",
        "-k",
        2,
        "--progress-every",
        0.1,
        "--config",
        small_config(tmp_path),
        "--out",
        board,
    )
    last = [line for line in scored.stdout.splitlines() if line.startswith("scoring:")][-1]
    assert re.match(
        r"scoring: 4 / 4 episodes \(100%\), .* episodes/s, 400 steps \(\d+ steps/s\), pass rate 0% of "
        r"the last 4, ETA",
        last,
    ), last

    from aaai.train.experiments import plot_runs

    picture = plot_runs([run], tmp_path / "curves.png", smooth=5)
    import cv2

    image = cv2.imread(str(picture))
    assert image is not None and image.std() > 10
    result = aaai_here("plot", tmp_path, "--out", tmp_path / "x.png", check=False)
    assert result.returncode == 2 and "config.yaml is missing" in result.stderr


def test_tensorboard_gets_the_task_return_without_shaping(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from aaai.config import load_config
    from aaai.train.training import train

    config = load_config(
        {
            "episode": {"max_steps": 30},
            "curriculum": {"levels": "0", "difficulties": "0-1"},
            "train": {
                "n_steps": 64,
                "batch_size": 64,
                "n_epochs": 1,
                "net_width": 16,
                "num_envs": 1,
                "total_steps": 128,
                "reward_shaping": 5.0,
            },
        }
    )
    train(tmp_path / "run", config, asynchronous=False)
    with open(tmp_path / "run" / "episodes.csv") as handle:
        episodes = list(csv.DictReader(handle))
    events = EventAccumulator(str(next((tmp_path / "run" / "tb").iterdir())))
    events.Reload()
    logged = {tag: [s.value for s in events.Scalars(tag)] for tag in events.Tags()["scalars"]}
    task = [float(e["task_return"]) for e in episodes]
    shaped = [float(e["episode_return"]) for e in episodes]
    assert logged["rollout/task_return_mean"][-1] == pytest.approx(sum(task) / len(task), rel=1e-5)
    assert logged["rollout/ep_rew_mean"][-1] == pytest.approx(sum(shaped) / len(shaped), rel=1e-5)
    assert abs(logged["rollout/task_return_mean"][-1] - logged["rollout/ep_rew_mean"][-1]) > 1e-3  # not the shaped one
    assert logged["rollout/food_eaten_mean"][-1] == pytest.approx(
        sum(int(e["food_eaten"]) for e in episodes) / len(episodes)
    )
    assert logged["rollout/pass_rate"][-1] == 0.0
    assert {"cells/pass_rate_L0_d0", "cells/pass_rate_L0_d1", "curriculum/p_L0_d0"} <= set(logged)


def test_train_sampler_option_and_random_alias_reach_the_runs_sampler(tmp_path):
    for extra, expected in (
        (["--sampler", "learnability"], "learnability"),
        (["--random"], "uniform"),  # with another --sampler it is refused (below)
    ):
        run = tmp_path / expected
        result = CliRunner().invoke(
            cli, ["train", "--agent", "random", "--steps", "50", "--envs", "1", "--run", str(run), *extra]
        )
        assert result.exit_code == 0, result.output
        assert read_state(run / "final")["curriculum"]["sampler"] == expected
    bad = CliRunner().invoke(cli, ["train", "--agent", "random", "--sampler", "best", "--run", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "'best'" in bad.output and "learnability" in bad.output


def test_a_new_run_of_mode_random_with_another_sampler_is_refused_before_its_folder(tmp_path):
    """curriculum.mode random samples uniformly: a config (or --random --sampler) naming another
    sampler would record one the run never uses."""
    from click.testing import CliRunner

    from aaai_cli.main import cli

    config = tmp_path / "c.yaml"
    config.write_text("curriculum:\n  mode: random\n  sampler: paper\n")
    run = tmp_path / "run"
    for extra in (["--config", str(config)], ["--random", "--sampler", "plr"]):
        result = CliRunner().invoke(cli, ["train", "--agent", "random", "--steps", "8", "--run", str(run), *extra])
        assert result.exit_code != 0 and "'curriculum.sampler'" in result.output and "mode random" in result.output
        assert not run.exists()


@pytest.fixture
def clock(monkeypatch):
    """The tracker's clock of training time made a count: each reading is one second later."""
    from itertools import count

    from aaai.train.training import Tracker

    ticks = count()
    monkeypatch.setattr(Tracker, "seconds", lambda self: self.seconds_before + next(ticks))


@pytest.mark.parametrize("agent", ["random", "ppo"])
def test_a_budget_of_minutes_ends_the_run_with_its_final_model_and_a_resume_says_it_is_spent(tmp_path, clock, agent):
    run = tmp_path / "run"
    config = small_config(tmp_path)
    args = ["train", "--agent", agent, "--steps", "5000", "--minutes", "0.5", "--config", str(config)]
    result = CliRunner().invoke(cli, [*args, "--run", str(run)])
    assert result.exit_code == 0, result.output
    state = read_state(run / "final")
    assert 0 < state["step"] < 400 and state["seconds"] >= 30  # stopped by the 30 s, long before 5,000 steps
    assert (run / "final" / "model.zip").is_file() == (agent == "ppo")
    assert yaml.safe_load((run / "config.yaml").read_text())["train"]["max_minutes"] == 0.5
    again = CliRunner().invoke(cli, ["train", "--resume", str(run)])
    assert again.exit_code == 2 and "whole budget of train.max_minutes 0.5" in again.output


def test_a_budget_of_minutes_is_refused_for_a_student_whose_budget_is_rounds(tmp_path):
    run = tmp_path / "student"
    result = CliRunner().invoke(cli, ["train", "--teacher", "reference", "--minutes", "5", "--run", str(run)])
    assert result.exit_code == 2 and "train.max_minutes" in result.output and "rounds of DAgger" in result.output
    assert not run.exists()
