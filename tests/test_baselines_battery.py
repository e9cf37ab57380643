"""aaai baselines --battery: the policies scored on an imported Animal-AI battery, and the table's
section per Olympics category."""

import csv
import io
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.scoring.evaluation import COLUMNS
from aaai.tools.baselines import tabulate
from aaai_cli.main import cli

ROOT = Path(__file__).resolve().parents[1]
HEADER = "# Imported from an Animal-AI arena file by `aaai import-animalai` (aaai/tools/animalai.py).\n"
# a tiny imported arena: the food 10 units ahead, 2 seconds (100 decisions) to reach it
ARENA = (
    HEADER + "description: a tiny test arena\narena_walls: true\narena_size: [60.0, 60.0]\nwall_height: 4.0\n"
    "time_limit: 2.0\npass_mark: 0.0\nreach: pass_mark\nagent: {x: 0.0, y: 0.0, yaw: 1.570796}\n"
    "objects:\n  - {kind: food_green, shape: sphere, position: [0.0, 12.0, 2.5], size: [5.0, 5.0, 5.0]}\n"
)


def _row(arena: str, outcome: str) -> dict:
    row = dict.fromkeys(COLUMNS, "0")
    row.update(level_name="food_contact", outcome=outcome, fell="False", arena=arena)
    return row


def _write(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    path.write_text(text.getvalue())


def _section(table: str) -> list[str]:
    lines = table.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("## Animal-AI battery"))
    return lines[start:]


def test_the_battery_section_counts_each_category_with_its_interval(tmp_path):
    _write(
        tmp_path / "battery" / "reference.csv",
        [
            _row("01-01-01.yaml", "succeeded"),
            _row("01-02-01.yaml", "failed"),
            _row("03-01-01.yaml", "passed"),
            _row("10-04-02.yaml", "succeeded"),
        ],
    )
    # the reference's sphere rows as experiments/limbs holds them (the scoreboard aaai eval --arenas writes)
    with open(ROOT / "experiments" / "limbs" / "reference_sphere_arenas.csv", newline="") as handle:
        limbs = [row for row, _ in zip(csv.DictReader(handle), range(3))]
    assert [row["arena"][:3] for row in limbs] == ["01-"] * 3
    _write(tmp_path / "battery" / "reference_sphere.csv", limbs)
    _write(tmp_path / "battery" / "random.csv", [_row("01-01-01.yaml", "failed")])
    tabulate(tmp_path)
    section = _section((tmp_path / "table.md").read_text())
    assert section[0] == "## Animal-AI battery (6 files valid on every seed)"
    assert section[2] == "| category | random | reference | reference, sphere |"
    passed_limbs = sum(row["outcome"] != "failed" for row in limbs)
    rows = {line.split(" | ")[0].strip("| "): line for line in section[4:]}
    assert len(rows) == 11  # the ten categories and all of them
    assert rows["01 food retrieval"].startswith("| 01 food retrieval | 0/1: 0% (0-79) | 1/2: 50% (9-91) | ")
    assert f"| {passed_limbs}/3: " in rows["01 food retrieval"]
    assert rows["03 obstacles"] == "| 03 obstacles | - | 1/1: 100% (21-100) | - |"
    assert rows["05 spatial reasoning"] == "| 05 spatial reasoning | - | - | - |"
    assert rows["10 causal reasoning"].startswith("| 10 causal reasoning | - | 1/1: 100% (21-100) |")
    assert rows["**all categories**"].startswith("| **all categories** | 0/1: 0% (0-79) | 3/4: 75% (30-95) | ")


def test_the_table_has_no_battery_section_without_battery_scoreboards(tmp_path):
    level_rows = [
        {**_row("", outcome), "level": "0", "difficulty": "0", "seed": str(seed)}
        for seed, outcome in enumerate(("passed", "failed"))
    ]
    _write(tmp_path / "reference.csv", level_rows)
    tabulate(tmp_path, levels=[0], difficulties=[0])
    table = (tmp_path / "table.md").read_text()
    assert "| L0 food_contact | 50% (9-91) |" in table and "Animal-AI battery" not in table
    _write(tmp_path / "battery" / "reference.csv", [_row("02-01-01.yaml", "passed")])
    tabulate(tmp_path, levels=[0], difficulties=[0])  # as aaai baselines --only does after the levels
    table = (tmp_path / "table.md").read_text()
    assert "| L0 food_contact | 50% (9-91) |" in table
    assert "| 02 preferences | 1/1: 100% (21-100) |" in _section(table)


def test_a_bad_battery_folder_is_refused_naming_it(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "01-01-01.yaml").write_text(ARENA)
    (foreign / "mine.yaml").write_text(ARENA.removeprefix(HEADER))
    cases = {
        tmp_path / "missing": "which is not a folder",
        empty: "holds no arena files (*.yaml) at its top level",
        foreign: "is not an import: mine.yaml was not written by `aaai import-animalai`",
    }
    for folder, why in cases.items():
        args = ["baselines", "--battery", str(folder), "--out", str(tmp_path / "out"), "--only", "reference"]
        refused = CliRunner().invoke(cli, args)
        assert refused.exit_code == 2, refused.output
        assert "Error: --battery: " in refused.output and str(folder) in refused.output, refused.output
        assert why in refused.output and "Traceback" not in refused.output
    assert not (tmp_path / "out" / "battery").exists()


def test_battery_options_need_battery_and_it_takes_no_level_options(tmp_path):
    out = ["--out", str(tmp_path / "out"), "--only", "reference"]
    refused = CliRunner().invoke(cli, ["baselines", *out, "--body", "sphere"])
    assert refused.exit_code == 2 and "--body: allowed only with --battery DIR" in refused.output
    refused = CliRunner().invoke(cli, ["baselines", *out, "--battery", str(tmp_path), "--levels", "0"])
    assert refused.exit_code == 2 and "--battery: got --levels with it" in refused.output


@pytest.mark.long  # two worker processes score two tiny arenas, three times: about 12 s
def test_aaai_baselines_scores_a_battery_and_resumes(tmp_path):
    battery = tmp_path / "import"
    battery.mkdir()
    for name in ("01-01-01.yaml", "04-02-01.yaml"):
        (battery / name).write_text(ARENA)
    out = tmp_path / "baselines"
    args = ["baselines", "--battery", str(battery), "--out", str(out), "--only", "random,reference", "--workers", "2"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "2 of 2 arena files valid for the quadruped on seeds 0-0" in result.output
    for name in ("random", "reference"):
        with open(out / "battery" / f"{name}.csv", newline="") as handle:
            rows = list(csv.DictReader(handle))
        assert list(rows[0]) == COLUMNS and [(r["arena"], r["seed"]) for r in rows] == [
            ("01-01-01.yaml", "0"),
            ("04-02-01.yaml", "0"),
        ]
    section = _section((out / "table.md").read_text())
    assert section[0] == "## Animal-AI battery (2 files valid on every seed)"
    again = CliRunner().invoke(cli, args)  # resumed: nothing left to score, the same rows
    assert again.exit_code == 0 and (out / "battery" / "random.csv").read_text().count("\n") == 3
    (battery / "04-02-01.yaml").write_text(ARENA.replace("12.0, 2.5", "14.0, 2.5"))  # a file changed
    changed = CliRunner().invoke(cli, args)
    assert changed.exit_code == 2 and f"{str(battery / '04-02-01.yaml')!r} is not the file" in changed.output, (
        changed.output
    )
