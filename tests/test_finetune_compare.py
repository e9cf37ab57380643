"""`aaai compare`: two scoreboards of the same episodes, per level, with the difference's interval
(how a fine-tuned student is compared with baselines/student.csv); and two recipes by several
training runs each, with Welch's interval over the runs."""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError
from aaai.tools.compare import compare, compare_runs, comparison_markdown, mcnemar, read_scoreboard, runs_markdown
from aaai_cli.main import cli

COLUMNS = ["level", "level_name", "difficulty", "seed", "return", "outcome", "arena"]


def board(passes: dict[int, int], episodes: int = 20) -> list[dict]:
    """Synthetic rows: per level, ``episodes`` seeds of difficulty 0, the first ``passes[level]`` passed."""
    return [
        {"level": str(level), "level_name": "x", "difficulty": "0", "seed": str(seed), "return": "0", "arena": "",
         "outcome": "passed" if seed < count else "failed"}
        for level, count in passes.items()
        for seed in range(episodes)
    ]  # fmt: skip


BASE = {0: 20, 1: 10, 2: 4, 3: 8, 4: 12, 5: 18}
OTHER = {0: 20, 1: 19, 2: 5, 3: 8, 4: 19, 5: 2}


def test_per_level_rates_differences_and_intervals():
    lines = compare(board(BASE), board(OTHER))
    assert [line.level for line in lines] == [0, 1, 2, 3, 4, 5, None]
    one = lines[1]
    assert (one.base.passes, one.other.passes, one.base.episodes) == (10, 19, 20)
    assert one.difference == pytest.approx(0.45)
    low, high = one.interval  # Newcombe's hybrid score interval of 19/20 - 10/20
    assert (low, high) == pytest.approx((0.1763, 0.6549), abs=1e-3)  # worked by hand
    assert lines[4].interval == pytest.approx((0.0902, 0.5673), abs=1e-3)  # 19/20 - 12/20, by hand too
    assert [line.verdict for line in lines] == [
        "no difference shown", "better", "no difference shown", "no difference shown", "better", "worse",
        "no difference shown",
    ]  # fmt: skip
    assert (lines[-1].base.passes, lines[-1].other.passes, lines[-1].base.episodes) == (72, 73, 120)
    # paired: the same seeds; on L1 only the tuned board passed 9 (seeds 10-18), on L5 only the base 16
    assert (one.gained, one.lost, one.paired_p) == (9, 0, pytest.approx(2 / 2**9))
    assert (lines[5].gained, lines[5].lost, lines[5].paired_p) == (0, 16, pytest.approx(2 / 2**16))
    assert lines[0].paired_p == 1.0  # no episode differs
    assert mcnemar(3, 5) == pytest.approx(2 * (1 + 8 + 28 + 56) / 256)  # by hand: 0.7266


def test_the_table_marks_the_weakest_levels_and_counts_where_it_is_better():
    table = comparison_markdown(compare(board(BASE), board(OTHER)), "student", "student_ppo")
    assert (
        "| L1 food_retrieval (weakest) | 20 | 50% (30-70) | 95% (76-99) | +45 (+18 to +65) | better | 9 / 0 | 0.0039 |"
        in table
    )
    assert "| L0 food_contact | 20 |" in table  # not among the 4 weakest (L2, L3, L1, L4)
    assert "better than student (the interval of the difference above 0) on 2 of student's 4 weakest" in table
    assert "(L1, L4); over all levels: no difference shown." in table


def test_only_the_episodes_both_hold_are_compared():
    partial = [row for row in board(OTHER) if int(row["seed"]) < 10]  # a scoreboard half scored
    lines = compare(board(BASE), partial)
    assert lines[-1].base.episodes == lines[-1].other.episodes == 60
    with pytest.raises(ConfigError, match="share no episode"):
        compare(board({0: 1}), board({1: 1}))


def write(path, rows):
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def test_the_command_prints_and_writes_the_table_and_refuses_what_is_not_a_scoreboard(tmp_path):
    write(tmp_path / "student.csv", board(BASE))
    write(tmp_path / "tuned.csv", board(OTHER))
    out = tmp_path / "comparison.md"
    result = CliRunner().invoke(
        cli, ["compare", str(tmp_path / "student.csv"), str(tmp_path / "tuned.csv"), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert (
        "| **all levels** | 120 | 60% (51-68) | 61% (52-69) | +1 (-11 to +13) | no difference shown | 17 / 16 | 1 |"
        in result.output
    )
    assert out.read_text() in result.output
    (tmp_path / "tuned").mkdir()
    write(tmp_path / "tuned" / "scoreboard_reserved.csv", board(OTHER))
    result = CliRunner().invoke(
        cli, ["compare", str(tmp_path / "student.csv"), str(tmp_path / "tuned" / "scoreboard_reserved.csv")]
    )
    assert "| level | episodes | student | tuned |" in result.output  # a run's scoreboard named by its run
    (tmp_path / "notes.csv").write_text("name,score\na,1\n")
    result = CliRunner().invoke(cli, ["compare", str(tmp_path / "student.csv"), str(tmp_path / "notes.csv")])
    assert result.exit_code == 2
    assert "notes.csv': has no column 'level'; allowed: a scoreboard CSV of aaai eval" in result.output
    assert "Traceback" not in result.output
    with pytest.raises(ConfigError, match="arena files' episodes"):
        write(tmp_path / "arenas.csv", [dict(board({0: 1})[0], arena="a.yaml")])
        read_scoreboard(tmp_path / "arenas.csv")


def test_two_recipes_compare_by_their_runs_spread():
    """Two runs a side: per level each run's rate, and Welch's interval of the difference of the means
    over the runs, the same as scipy's own Welch interval; a level where the runs agree within a
    side and the sides differ a lot is better, one where a side's runs disagree is not shown."""
    from scipy import stats

    bases = [board({0: 20, 1: 10, 2: 2}), board({0: 20, 1: 12, 2: 18})]
    others = [board({0: 20, 1: 19, 2: 19}), board({0: 20, 1: 18, 2: 3})]
    lines = compare_runs(bases, others)
    assert [line.level for line in lines] == [0, 1, 2, None]
    one = lines[1]
    assert (one.base, one.other, one.episodes) == ((0.5, 0.6), (0.95, 0.9), 20)
    assert one.difference == pytest.approx(0.375)
    expected = stats.ttest_ind([0.95, 0.9], [0.5, 0.6], equal_var=False).confidence_interval(0.95)
    assert one.interval == pytest.approx((expected.low, expected.high))
    assert one.verdict == "better"
    assert lines[2].difference == pytest.approx(0.05) and lines[2].verdict == "no difference shown"
    assert lines[0].unspread and lines[0].verdict == "no difference shown"  # no spread, no difference
    assert lines[-1].base == (32 / 60, 50 / 60)
    table = runs_markdown(lines, ["student", "student_b"], ["memory", "memory_b"])
    assert "| L1 food_retrieval | 20 | 50 / 60 | 55% | 95 / 90 | 92% | +38 (" in table
    assert "| level | episodes | student (2 runs): each run | mean | memory (2 runs): each run |" in table
    assert "student, student_b against memory, memory_b" in table


def test_runs_without_spread_are_judged_by_the_episodes_chance_alone():
    """Where every run of each side passes the same count, Welch's interval has no spread to stand on
    and would shrink to the point: one episode more in 110 on every run of one side would be "better".
    The interval is then the episodes' (Newcombe's on one run's episodes), and the table marks it."""
    lines = compare_runs([board({2: 60}, 110)] * 2, [board({2: 61}, 110)] * 3)
    level = lines[0]
    assert level.unspread and level.difference == pytest.approx(1 / 110)
    from aaai.tools.compare import Rate, newcombe

    assert level.interval == pytest.approx(newcombe(Rate(60, 110), Rate(61, 110)))
    assert level.interval[0] < -0.1 and level.interval[1] > 0.1
    assert level.verdict == "no difference shown"
    spread = compare_runs([board({2: 60}, 110), board({2: 62}, 110)], [board({2: 61}, 110)] * 2)[0]
    assert not spread.unspread  # one side's runs differ: Welch's over the runs, as before
    table = runs_markdown(lines, ["a", "a2"], ["b", "b2", "b3"])
    assert "| +1 (-12 to +14) * | no difference shown |" in table


def test_runs_are_compared_on_the_episodes_every_run_holds_and_need_two_a_side():
    half = [row for row in board(OTHER) if int(row["seed"]) < 10]
    lines = compare_runs([board(BASE), board(BASE)], [board(OTHER), half])
    assert lines[-1].episodes == 60
    with pytest.raises(ConfigError, match="1 training run of the base; allowed: 2 or more a side"):
        compare_runs([board(BASE)], [board(OTHER), board(OTHER)])


def test_the_command_compares_recipes_when_given_more_runs(tmp_path):
    for name, passes in (("a", BASE), ("a2", BASE), ("b", OTHER), ("b2", OTHER)):
        write(tmp_path / f"{name}.csv", board(passes))
    paths = {name: str(tmp_path / f"{name}.csv") for name in ("a", "a2", "b", "b2")}
    result = CliRunner().invoke(
        cli, ["compare", paths["a"], paths["b"], "--base-run", paths["a2"], "--other-run", paths["b2"]]
    )
    assert result.exit_code == 0, result.output
    assert "| L1 food_retrieval | 20 | 50 / 50 | 50% | 95 / 95 | 95% | +45 (+18 to +65) * | better |" in result.output
    assert "\\* Every run of a side passed as many episodes as the other runs of its side" in result.output
    result = CliRunner().invoke(cli, ["compare", paths["a"], paths["b"], "--base-run", paths["a2"]])
    assert result.exit_code == 2
    assert "1 training run of the other; allowed: 2 or more a side" in result.output
    assert "Traceback" not in result.output
