"""`aaai train` and `aaai eval`: the refusals of flags that cannot go together, and the Python calls the
commands make (aaai.scoring.eval_job.score_policy, aaai.train.launch), reachable without click."""

import csv
import errno
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError, config_dir, load_config
from aaai.jobs import Progress, quietly
from aaai.scoring.eval_job import score_policy
from aaai.train.launch import check_options, train_run
from aaai_cli.main import cli

ARENA = config_dir() / "arenas" / "l0_food_ahead.yaml"


@pytest.fixture
def no_training(monkeypatch):
    """A refusal comes before any trainer starts: a trainer that starts fails the test at once."""

    def trainer(*args, **kwargs):
        raise AssertionError("a trainer started")

    for name in ("aaai.train.launch.train", "aaai.train.launch.train_rllib", "aaai.train.student.train_student"):
        monkeypatch.setattr(name, trainer)


@pytest.fixture(scope="module")
def short_config(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("config") / "short.yaml"
    path.write_text("episode: {max_steps: 15}\n")
    return str(path)


def rows_of(path: Path) -> list[dict]:
    with path.open() as handle:
        return list(csv.DictReader(line for line in handle if not line.startswith("#")))


@pytest.mark.parametrize(
    "args, message",
    [
        (["train", "--address", "10.0.0.1:6379"], "--address: only --backend rllib runs on a cluster"),
        (
            ["train", "--teacher", "reference", "--backend", "rllib"],
            "--teacher: a student is trained with stable-baselines3 (--backend sb3)",
        ),
        (
            ["train", "--teacher", "reference", "--steps", "100"],
            "--steps: got 100 for a student of a teacher, whose budget is rounds of DAgger",
        ),
        (["train", "--rounds", "3"], "--rounds: got 3 for a PPO run, whose budget is steps; allowed: --steps"),
        (["eval", "--arenas", str(ARENA), "--levels", "0"], "--arenas: --levels cannot be used with it"),
        (
            ["eval", "--arenas", str(ARENA), "--backend", "ray"],
            "--arenas: --backend ray cannot be used with it (an arena file is its own level)",
        ),
        (["eval", "--save-replays", "replays", "--backend", "ray"], "--save-replays: only with --backend local"),
        (["eval", "--arenas", str(ARENA), "--seeds", "train"], "--seeds: got 'train' with --arenas"),
    ],
)
def test_flags_that_cannot_go_together_are_refused_before_any_work(args, message, tmp_path, monkeypatch, no_training):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, [*args, *(["--run", "run"] if args[0] == "train" else [])])
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []  # nothing written: no run folder, scoreboard or replays


def test_the_trainer_rules_hold_for_a_python_caller(tmp_path, no_training):
    with pytest.raises(ConfigError, match="--address: only --backend rllib"):
        check_options(None, "sb3", "10.0.0.1:6379", [])
    with pytest.raises(ConfigError, match="--levels, --envs cannot change on resume"):
        check_options(str(tmp_path), None, None, ["levels", "envs"])
    check_options(str(tmp_path), None, None, [])  # --resume alone (with --steps) is allowed
    student = load_config(None, teacher="reference")
    with pytest.raises(ConfigError, match="a student is trained with stable-baselines3"):
        train_run(str(tmp_path / "run"), student, backend="rllib")
    with pytest.raises(ConfigError, match="--steps: got 5 for a student"):
        train_run(str(tmp_path / "run"), student, total_steps=5)
    assert not (tmp_path / "run").exists()


def test_score_policy_scores_as_aaai_eval_does_and_reports_its_progress(tmp_path, short_config):
    """The Python call behind `aaai eval`: the same scoreboard rows as the command, its summary, and
    a progress report told of every episode."""
    reports: list[Progress] = []

    def display(report: Progress):
        reports.append(report)
        return quietly(report)

    result = score_policy(
        "random",
        seeds="3,4",
        levels=[0],
        difficulties=[0, 1],
        config_path=short_config,
        output=tmp_path / "api.csv",
        display=display,
    )
    assert [(row["level"], row["difficulty"], row["seed"]) for row in result.rows] == [
        ("0", "0", "3"),
        ("0", "0", "4"),
        ("0", "1", "3"),
        ("0", "1", "4"),
    ]
    assert result.output == tmp_path / "api.csv" and len(rows_of(result.output)) == 4
    assert result.summary[-1]["level"] == "overall" and result.summary[-1]["episodes"] == 4
    assert result.write_summary() == tmp_path / "api_summary.md"
    (report,) = reports
    assert (report.total, report.done, report.episodes, report.unit) == (4, 4, 4, "episodes")
    assert report.env_steps == sum(int(row["steps"]) for row in result.rows)

    board = tmp_path / "cli.csv"
    args = ["eval", "--policy", "random", "--seeds", "3,4", "--levels", "0", "--difficulty", "0-1"]
    command = CliRunner().invoke(cli, [*args, "--config", short_config, "--out", str(board)])
    assert command.exit_code == 0, command.output
    timing = ("wall_seconds",)
    strip = lambda rows: [{k: v for k, v in row.items() if k not in timing} for row in rows]  # noqa: E731
    assert strip(rows_of(board)) == strip(rows_of(result.output))
    assert (tmp_path / "cli_summary.md").read_text() == (tmp_path / "api_summary.md").read_text()


def test_score_policy_scores_a_battery_of_arena_files(tmp_path, short_config):
    result = score_policy("random", seeds="0,1", arenas=ARENA, config_path=short_config, output=tmp_path / "a.csv")
    assert [(row["arena"], row["seed"]) for row in result.rows] == [(ARENA.name, "0"), (ARENA.name, "1")]
    assert result.output == tmp_path / "a.csv" and len(rows_of(result.output)) == 2
    assert f"arena {ARENA.name}" in [line["level"] for line in result.summary]
    with pytest.raises(ConfigError, match="--seeds: got 'train' with --arenas"):
        score_policy("random", seeds="train", arenas=ARENA, output=tmp_path / "b.csv")


def test_an_os_error_while_scoring_is_one_line_naming_the_scoreboard(tmp_path, short_config, monkeypatch):
    """A write that fails without naming its file (a full disk) is named by the scoreboard: one line for
    the command, an OSError for a Python caller."""

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("aaai.scoring.eval_job.evaluate", full_disk)
    out = tmp_path / "board.csv"
    with pytest.raises(OSError) as raised:
        score_policy("random", seeds="3", levels=[0], difficulties=[0], config_path=short_config, output=out)
    assert str(raised.value) == f"{str(out)!r}: No space left on device"
    args = ["eval", "--seeds", "3", "--levels", "0", "--difficulty", "0", "--config", short_config, "--out", str(out)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1 and result.output == f"Error: {str(out)!r}: No space left on device\n"


def test_a_summary_that_cannot_be_written_is_printed_and_named(tmp_path, short_config, monkeypatch):
    def refused(summary, output):
        raise OSError(errno.EACCES, "Permission denied", str(output.with_name("board_summary.md")))

    monkeypatch.setattr("aaai.scoring.eval_job.write_summary", refused)
    out = tmp_path / "board.csv"
    args = ["eval", "--seeds", "3", "--levels", "0", "--difficulty", "0", "--config", short_config, "--out", str(out)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1 and "| overall | 1 |" in result.output
    message = " ".join(result.output.split())
    summary = str(tmp_path / "board_summary.md")
    assert f"cannot write the summary {summary!r}: Permission denied; the scoreboard {str(out)!r} is whole" in message
    assert len(rows_of(out)) == 1
