"""Humans against agents: `aaai eval --study` scores a policy on exactly a study's battery, and
`aaai study report` puts two simulated participants beside two policies and the baseline table."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.study.store import Store
from aaai.study.studyfile import load_study
from aaai.tools.baselines import wilson
from aaai_cli.main import cli

ROOT = Path(__file__).resolve().parents[1]
BASELINE_SEED = 1428112445  # a reserved L0 d0 seed of the committed baseline table
STUDY = f"""\
name: versus
practice:
  - {{level: 0, difficulty: 0, seed: 7}}
  - {{level: 0, difficulty: 0, seed: 1}}
battery:
  - {{level: 0, difficulty: 0, seed: 1}}
  - {{level: 0, difficulty: 1, seed: 2}}
  - {{level: 0, difficulty: 0, seed: {BASELINE_SEED}}}
order: fixed
camera_resolution: 16
"""
# Each participant's outcome and reaction time (s) per battery trial, in the battery's order.
PEOPLE = {
    "P001": [("succeeded", 0.5), ("passed", 0.7), ("succeeded", 0.9)],
    "P002": [("succeeded", 1.1), ("failed", None), ("failed", 2.0)],
}

# Each participant's path (metres the trunk travelled) per battery trial.
PATHS = {"P001": [4.0, 6.5, 3.0], "P002": [12.25, 20.0, 9.0]}


def human_row(trial, outcome: str, steps: int) -> dict:
    return {
        "level": trial["level"],
        "level_name": "food_contact",
        "difficulty": trial["difficulty"],
        "seed": trial["seed"],
        "return": 3.9 if outcome != "failed" else -1.0,
        "max_reward": 3.5,
        "ratio": 1.1 if outcome != "failed" else -0.3,
        "outcome": outcome,
        "steps": steps,
        "max_steps": 1000,
        "food_eaten": int(outcome != "failed"),
        "wall_hits": 0,
        "fell": False,
        "arena": "",
        "wall_seconds": 1.0,
    }


def simulate(study) -> None:
    """Two participants' trials written through the store's API, as `aaai study serve` writes them;
    P001 also finishes the practice trials (which the report leaves out), one the same as a battery trial."""
    store = Store(study.store, study.name)
    try:
        store.add_participants(study, 2)
        for pid, results in PEOPLE.items():
            trials = store.trials(pid)
            practice, battery = trials[:2], trials[2:]
            for trial in practice if pid == "P001" else []:
                store.start_trial(pid, trial["position"])
                store.finish_trial(pid, trial["position"], human_row(trial, "failed", 50), {}, 0.1)
            for number, (trial, (outcome, reaction)) in enumerate(zip(battery, results)):
                store.start_trial(pid, trial["position"])
                if (pid, number) in (("P002", 1), ("P002", 2)):  # two trials of P002 were left once first
                    attempt = store.begin_attempt(pid, trial["position"])
                    store.save_attempt(
                        pid, trial["position"], attempt, {"steps": 40}, "abandoned", "the tab was closed"
                    )
                    store.begin_attempt(pid, trial["position"])  # the attempt that finishes
                row, path = human_row(trial, outcome, 100 + 10 * number), PATHS[pid][number]
                store.finish_trial(pid, trial["position"], row, {}, reaction, path)
            store.finish(pid)
    finally:
        store.close()


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("versus")
    study_file = folder / "study.yaml"
    study_file.write_text(STUDY)
    simulate(load_study(study_file))
    runner = CliRunner()
    boards = {}
    for policy in ("reference", "random"):
        boards[policy] = folder / f"{policy}.csv"
        replays = ["--save-replays", str(folder / "reference_replays")] if policy == "reference" else []
        result = runner.invoke(
            cli, ["eval", "--study", str(study_file), "--policy", policy, "--out", str(boards[policy]), *replays]
        )
        assert result.exit_code == 0, result.output
    # The baseline table: two committed tables, and one with no row on the study's trials (left out).
    baselines = folder / "baselines"
    baselines.mkdir()
    for name in ("reference", "random"):
        shutil.copy(ROOT / "baselines" / f"{name}.csv", baselines)
    lines = (ROOT / "baselines" / "reference.csv").read_text().splitlines()
    (baselines / "elsewhere.csv").write_text(
        "\n".join([lines[0], *[x for x in lines[1:] if x.startswith("1,")]]) + "\n"
    )
    out = folder / "report"
    arguments = ["study", "report", str(study_file), "--out", str(out), "--baselines", str(baselines)]
    for board in boards.values():
        arguments += ["--policy-scores", str(board)]
    arguments += ["--policy-replays", str(folder / "reference_replays")]
    result = runner.invoke(cli, arguments)
    assert result.exit_code == 0, result.output
    with open(out / "report.csv", newline="") as handle:
        rows = {(r["scope"], r["name"], r["who"]): r for r in csv.DictReader(handle)}
    return folder, study_file, boards, out, rows


def test_eval_study_scores_exactly_the_battery_without_the_practice(made):
    _, _, boards, _, _ = made
    for board in boards.values():
        with open(board, newline="") as handle:
            scored = [(int(r["level"]), int(r["difficulty"]), int(r["seed"])) for r in csv.DictReader(handle)]
        assert scored == [(0, 0, 1), (0, 1, 2), (0, 0, BASELINE_SEED)]
    assert json.loads(boards["reference"].with_name("reference_scored_with.json").read_text())["seeds"] == "study"


def test_the_report_counts_each_players_trials_with_wilson_intervals(made):
    _, _, _, _, rows = made
    humans = rows[("level", "L0", "humans")]  # 4 of 6 battery trials passed; the practice left out
    low, high = wilson(4, 6)
    assert (humans["episodes"], humans["passed"]) == ("6", "4")
    assert float(humans["low"]) == pytest.approx(low, rel=1e-3) and float(humans["high"]) == pytest.approx(
        high, rel=1e-3
    )
    assert rows[("trial", "L0 d1 s2", "humans")]["passed"] == "1"
    assert rows[("trial", "L0 d0 s1", "humans")]["high"] == "1"
    assert float(humans["reaction_median"]) == pytest.approx(0.9)  # of 0.5, 0.7, 0.9, 1.1, 2.0
    assert float(rows[("trial", "L0 d0 s1", "humans")]["steps_median"]) == 100
    # paths in metres: of 3, 4, 6.5, 9, 12.25, 20 the median is 7.75, the quartiles 4.625 and 11.44
    assert float(humans["path_median_m"]) == pytest.approx(7.75)
    assert (humans["path_q1_m"], humans["path_q3_m"]) == ("4.625", "11.44")
    assert rows[("trial", "L0 d1 s2", "humans")]["path_median_m"] == "13.25"
    # a policy's paths, from its replays (random's were not saved: no paths)
    assert 2.0 < float(rows[("level", "L0", "reference")]["path_median_m"]) < 20.0
    assert (
        rows[("trial", "L0 d0 s1", "reference")]["path_q1_m"]
        == rows[("trial", "L0 d0 s1", "reference")]["path_median_m"]
    )
    assert rows[("level", "L0", "random")]["path_median_m"] == ""
    # attempts left unfinished, and played again, are counted for the humans
    assert humans["abandoned"] == "2" and rows[("trial", "L0 d1 s2", "humans")]["abandoned"] == "1"
    assert rows[("trial", "L0 d0 s1", "humans")]["abandoned"] == "0"
    assert rows[("level", "L0", "reference")]["abandoned"] == ""
    for policy in ("reference", "random"):
        assert rows[("level", "L0", policy)]["episodes"] == "3"
        assert rows[("trial", "L0 d0 s1", policy)]["episodes"] == "1"
    assert rows[("level", "L0", "reference")]["passed"] == "3"
    # The baseline table's rows join only on the study's own (level, difficulty, seed).
    assert rows[("level", "L0", "baseline:reference")]["episodes"] == "1"
    assert rows[("trial", f"L0 d0 s{BASELINE_SEED}", "baseline:random")]["episodes"] == "1"
    assert rows[("trial", "L0 d0 s1", "baseline:reference")]["episodes"] == "0"
    assert not any(who == "baseline:elsewhere" for _, _, who in rows)


def test_the_report_writes_its_table_and_a_png_figure(made):
    _, _, _, out, _ = made
    text = (out / "report.md").read_text()
    low, high = wilson(4, 6)
    interval = f"{100 * low:.0f}-{100 * high:.0f}%"
    assert f"| L0 | humans | 67% | {interval} | 4/6 | 2 | 0.90 (0.70-1.10) | 7.8 (4.6-11.4) | 110 |" in text
    assert "2 participants" in text and "| L0 | baseline:reference | 100% | 21-100% | 1/1 | - | - | - | 93 |" in text
    assert "path the body's trunk travelled in metres (1 world unit = 1 m)" in text
    assert (out / "report.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "extra, named",
    [
        (["--levels", "0"], "--levels"),
        (["--seeds", "1,2"], "--seeds"),
        (["--difficulty", "0"], "--difficulty"),
        (["--arenas", "."], "--arenas"),
    ],
)
def test_eval_study_refuses_the_options_that_choose_other_episodes(made, extra, named):
    _, study_file, _, _, _ = made
    result = CliRunner().invoke(cli, ["eval", "--study", str(study_file), *extra])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert f"--study: got {str(study_file)!r} with {named}; allowed: --study alone" in result.output


def test_report_refuses_a_missing_scoreboard_by_name(made, tmp_path):
    _, study_file, _, _, _ = made
    missing = tmp_path / "nothing.csv"
    result = CliRunner().invoke(
        cli, ["study", "report", str(study_file), "--policy-scores", str(missing), "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 2 and f"--policy-scores: {str(missing)!r} does not exist" in result.output


def test_report_refuses_a_scoreboard_of_other_trials(made, tmp_path):
    _, study_file, _, _, _ = made
    other = tmp_path / "levels.csv"
    with open(ROOT / "baselines" / "random.csv") as handle:
        lines = handle.read().splitlines()
    other.write_text("\n".join([lines[0], *[x for x in lines[1:] if x.startswith("1,")][:2]]) + "\n")
    result = CliRunner().invoke(
        cli, ["study", "report", str(study_file), "--policy-scores", str(other), "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 2, result.output
    assert "--policy-scores: the scoreboard of 'levels' holds none of study 'versus''s trials" in result.output


def test_report_refuses_policy_replays_it_cannot_use_naming_them(made, tmp_path):
    folder, study_file, boards, _, _ = made
    base = [
        "study",
        "report",
        str(study_file),
        "--policy-scores",
        str(boards["reference"]),
        "--out",
        str(tmp_path / "r"),
    ]
    empty = tmp_path / "empty"
    empty.mkdir()
    result = CliRunner().invoke(cli, [*base, "--policy-replays", str(empty)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert f"--policy-replays: {str(empty)!r} holds no replay of a --policy-scores policy" in result.output
    assert "(policies: reference)" in result.output
    altered = tmp_path / "altered"
    altered.mkdir()
    original = sorted((folder / "reference_replays").glob("*.json"))[0]
    replay = json.loads(original.read_text())
    replay["return"] = 0.0  # not what its actions give
    (altered / original.name).write_text(json.dumps(replay))
    result = CliRunner().invoke(cli, [*base, "--policy-replays", str(altered)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert f"--policy-replays: {str(altered / original.name)!r}: it does not run as recorded (return" in result.output
