"""make baselines: three scoreboards, a pass-rate table and a heatmap, on the reserved seeds."""

import csv
from pathlib import Path

import cv2
import pytest
from click.testing import CliRunner

from aaai.levels.seeds import reserved_seeds
from aaai.scoring.evaluation import COLUMNS
from aaai_cli.main import cli


def test_aaai_baselines_scores_three_policies_and_tabulates_them(tmp_path):
    run = tmp_path / "demo"
    trained = CliRunner().invoke(
        cli, ["train", "--agent", "random", "--steps", "200", "--envs", "1", "--run", str(run)]
    )
    assert trained.exit_code == 0, trained.output
    out = tmp_path / "baselines"
    result = CliRunner().invoke(
        cli,
        [
            "baselines",
            "--demo-run",
            str(run),
            "--out",
            str(out),
            "--levels",
            "0,8",
            "--difficulty",
            "0,10",
            "-k",
            "2",
            "--workers",
            "2",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "min on 2 workers" in result.output  # how long it took
    boards = {}
    for name in ("random", "reference", "ppo_demo"):
        with open(out / f"{name}.csv", newline="") as handle:
            rows = list(csv.DictReader(handle))
        assert list(rows[0]) == COLUMNS
        assert [(int(r["level"]), int(r["difficulty"]), int(r["seed"])) for r in rows] == [
            (level, d, seed) for level in (0, 8) for d in (0, 10) for seed in sorted(reserved_seeds(level, d, 2))
        ]
        boards[name] = rows
    passed = {name: sum(r["outcome"] != "failed" for r in rows) for name, rows in boards.items()}
    assert passed["reference"] > passed["random"]
    table = (out / "table.md").read_text()
    assert "| L8 object_permanence |" in table and "**all levels**" in table
    reference_share = 100 * passed["reference"] // 8
    assert f"{reference_share}%" in table
    picture = cv2.imread(str(out / "heatmap.png"))
    assert picture is not None and picture.shape[1] > 3 * picture.shape[0] / 2  # three panels side by side


def test_aaai_baselines_needs_a_trained_run(tmp_path):
    result = CliRunner().invoke(cli, ["baselines", "--demo-run", str(tmp_path / "missing"), "--out", str(tmp_path)])
    assert result.exit_code == 2 and "make demo" in result.output


def test_the_docs_show_the_committed_baseline_table():
    """docs/baselines.md shows baselines/table.md's table as committed, and the README's summary
    its 'all levels' row for each policy: a re-scored table cannot leave the pages behind."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    table = (root / "baselines" / "table.md").read_text().splitlines()
    committed = [line for line in table if line.startswith("|")]
    docs = (root / "docs" / "baselines.md").read_text().splitlines()
    assert all(line in docs for line in committed), "docs/baselines.md differs from baselines/table.md"
    levels = table[: next((i for i, s in enumerate(table) if s.startswith("## ")), None)]
    header, _, *_, totals = [line for line in levels if line.startswith("|")]  # the levels' table, not the battery's
    cells = [cell.strip() for cell in totals.strip("|").split("|")]
    policies = [cell.strip().removesuffix(": all") for cell in header.strip("|").split("|")[1::2]]
    readme = (root / "README.md").read_text()
    for index, policy in enumerate(policies):
        assert f"| {policy} | {cells[1 + 2 * index]} | {cells[2 + 2 * index]} |" in readme, policy


@pytest.mark.long  # trains a tiny run and scores it in a worker process: about 15 s
def test_aaai_baselines_scores_any_trained_run_given_as_learned(tmp_path):
    run = tmp_path / "tiny"
    trained = CliRunner().invoke(
        cli, ["train", "--agent", "random", "--steps", "100", "--envs", "1", "--run", str(run)]
    )
    assert trained.exit_code == 0, trained.output
    out = tmp_path / "baselines"
    args = ["baselines", "--out", str(out), "--levels", "0", "--difficulty", "0", "-k", "1", "--workers", "1"]
    model = Path(__file__).resolve().parents[1] / "baselines" / "models" / "student.zip"  # a committed model file
    given = ["--learned", f"my_run2={run}", "--learned", f"my_model={model}", "--only", "my_run2,my_model"]
    result = CliRunner().invoke(cli, [*args, *given])
    assert result.exit_code == 0, result.output
    header = (out / "table.md").read_text().splitlines()[0]
    assert (out / "my_run2.csv").is_file() and "my_run2" in header
    assert (out / "my_model.csv").is_file() and "my_model" in header


def test_aaai_baselines_refuses_a_learned_run_badly_named_or_missing(tmp_path):
    args = ["baselines", "--out", str(tmp_path / "out"), "--levels", "0", "--difficulty", "0", "-k", "1"]
    (tmp_path / "notes.txt").write_text("not a model")
    for bad in (
        "My-Run=x",
        f"reference={tmp_path}",
        f"student_x={tmp_path}/missing",
        f"student_x={tmp_path}/missing.zip",
        f"student_x={tmp_path}/notes.txt",
        "noequals",
    ):
        refused = CliRunner().invoke(cli, [*args, "--learned", bad, "--only", "reference"])
        assert refused.exit_code == 2 and f"--learned: got {bad!r}" in refused.output, (bad, refused.output)
