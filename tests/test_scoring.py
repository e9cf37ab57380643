"""Scoring rules a published score depends on: seed ranges, the pass mark, the summary's counts
and the episode plan both backends play. Each test says what it guards."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from aaai.config import ConfigError, config_dir, load_config
from aaai.levels.seeds import RESERVED_SEEDS, TRAIN_SEEDS, reserved_seeds, seed_range, training_seed
from aaai.scoring.evaluation import Cell, episode_plan, evaluate, outcome, summarise


def test_training_and_reserved_seeds_meet_without_overlap():
    """Guards the split of seeds: the last training seed is a training seed, the next one is the
    first reserved seed (moving either boundary turns this red), and reserved lists stay reserved."""
    last_train = 1288490240 - 1
    assert seed_range(last_train) is TRAIN_SEEDS
    assert seed_range(last_train + 1) is RESERVED_SEEDS
    assert RESERVED_SEEDS.start == last_train + 1 == TRAIN_SEEDS.stop
    assert all(seed_range(s) is RESERVED_SEEDS for s in reserved_seeds(3, 1, 20))
    import numpy as np

    rng = np.random.default_rng(0)
    assert all(seed_range(training_seed(rng)) is TRAIN_SEEDS for _ in range(200))


@pytest.mark.parametrize(
    "ratio, expected",
    [
        (0.799, "failed"),
        (0.7999999, "failed"),
        (0.8, "passed"),
        (0.999, "passed"),
        (1.0, "succeeded"),
        (1.5, "succeeded"),
        (0.7, "failed"),
        (-0.5, "failed"),
    ],
)
def test_pass_mark_is_eight_tenths(ratio, expected):
    """Guards the pass mark (0.8, as in Animal-AI): 0.799 fails, 0.8 passes, 1.0 succeeds.
    Moving the mark to 0.7 turns the 0.7 and 0.799 cases red."""
    assert outcome(ratio) == expected


def _row(level, outcome_, ratio, ret=0.0):
    return {
        "level": str(level),
        "level_name": {0: "food_only", 3: "avoidance"}.get(level, "food_only"),
        "outcome": outcome_,
        "ratio": str(ratio),
        "return": str(ret),
    }


def test_summary_counts_passed_and_succeeded_as_passing():
    """Guards the summary's "passed or better": succeeded and passed both count, failed does not
    (counting only "passed" gives 25% here, not 50%)."""
    rows = [
        _row(0, "succeeded", 1.0, 1.0),
        _row(0, "passed", 0.85, 0.8),
        _row(0, "failed", 0.1, 0.0),
        _row(0, "failed", 0.2, 0.1),
    ]
    overall = summarise(rows)[-1]
    assert overall["level"] == "overall" and overall["episodes"] == 4
    assert overall["passed_pct"] == 50.0
    assert overall["succeeded_pct"] == 25.0
    assert overall["mean_return"] == pytest.approx(0.475)


def test_the_plan_plays_each_episode_once_and_skips_scored_ones():
    """Guards the de-duplication both backends rely on (the Ray backend plays this same plan):
    seeds [5, 5, 6] are two episodes, and a resumed scoreboard's rows are not played again."""
    cells = [Cell(0, 0, [5, 5, 6]), Cell(0, 0, [6, 7])]
    assert episode_plan(cells, []) == [(0, 0, 5), (0, 0, 6), (0, 0, 7)]
    scored = [{"level": "0", "difficulty": "0", "seed": "6", "arena": ""}]
    assert episode_plan(cells, scored) == [(0, 0, 5), (0, 0, 7)]
    arena_row = [{"level": "0", "difficulty": "0", "seed": "5", "arena": "a.yaml"}]  # an arena's row is another episode
    assert episode_plan(cells, arena_row) == [(0, 0, 5), (0, 0, 6), (0, 0, 7)]


def test_local_eval_of_repeated_seeds_gives_one_row_each(tmp_path):
    """Guards the local backend: seeds [5, 5, 6] give two rows, not three."""
    output = tmp_path / "board.csv"
    evaluate("random", [Cell(0, 0, [5, 5, 6])], output, load_config(None, max_steps=20))
    with output.open() as handle:
        seeds = [row["seed"] for row in csv.DictReader(line for line in handle if not line.startswith("#"))]
    assert seeds == ["5", "6"]


# --- the scoreboard file: rows, records, resume ----------------------------------------------
def _board(path, rows, columns=None):
    from aaai.scoring.evaluation import COLUMNS

    columns = columns or COLUMNS
    path.write_text(
        ",".join(columns) + "\n" + "".join(",".join(row.get(c, "1") for c in columns) + "\n" for row in rows)
    )


def test_a_torn_last_line_is_cut_and_a_line_torn_mid_file_is_played_again(tmp_path):
    """Guards resume after a crash: a last line cut short is removed from the file (so the next row
    starts on a line of its own), and a short line inside the file is dropped, its episode played again."""
    from aaai.scoring.evaluation import scored_episodes

    board = tmp_path / "board.csv"
    _board(board, [{"seed": "1"}, {"seed": "2"}])
    whole = board.read_text()
    board.write_text(whole + "0,food_only,0,3,0.5")  # a row cut short by a kill
    assert [r["seed"] for r in scored_episodes(board)] == ["1", "2"]
    assert board.read_text() == whole
    lines = whole.splitlines(keepends=True)
    board.write_text(lines[0] + lines[1] + "0,food_only,0,9\n" + lines[2])  # torn, then appended to
    assert [r["seed"] for r in scored_episodes(board)] == ["1", "2"]
    assert board.read_text() == whole
    assert scored_episodes(tmp_path / "none.csv") == []


def test_an_older_scoreboard_is_read_and_added_to_in_its_own_columns_and_a_foreign_file_refused(tmp_path):
    from aaai.scoring.evaluation import COLUMNS, LEGACY_COLUMNS, columns_of, scored_episodes

    old = tmp_path / "old.csv"
    _board(old, [{"seed": "4"}], LEGACY_COLUMNS)
    assert [(r["seed"], r["arena"]) for r in scored_episodes(old)] == [("4", "")]
    assert columns_of(old) == LEGACY_COLUMNS
    assert columns_of(tmp_path / "new.csv") == COLUMNS
    current = tmp_path / "current.csv"
    _board(current, [{"seed": "4"}])
    assert columns_of(current) == COLUMNS
    foreign = tmp_path / "foreign.csv"
    foreign.write_text("a,b\n1,2\n")
    with pytest.raises(
        ConfigError, match=r"'.*foreign.csv' is not a scoreboard of this version \(columns \['a', 'b'\]\)"
    ):
        scored_episodes(foreign)


def test_rows_are_durable_the_record_comes_with_the_first_and_a_failed_write_is_cut_back(tmp_path, monkeypatch):
    """Guards the row writer: nothing before the first row, then the record and header with it;
    a row that cannot be made durable is cut off again, named with the file and the rows kept."""
    import json

    from aaai.scoring.evaluation import COLUMNS, Scoreboard, record_path

    board, written = tmp_path / "board.csv", []
    row = {c: "1" for c in COLUMNS}
    with Scoreboard(board, {"policy": "p"}, COLUMNS, [], written.append) as scores:
        assert not board.exists() and not record_path(board).exists()
        scores.append({**row, "seed": 1, "extra": "not a column"})
        assert json.loads(record_path(board).read_text()) == {"policy": "p"}
        assert board.read_text().splitlines() == [",".join(COLUMNS), ",".join(row.values())]
        assert written == [{**row, "seed": 1, "extra": "not a column"}] and scores.rows[0]["seed"] == "1"
        record_path(board).write_text("kept\n")
        scores.append({**row, "seed": 2})
        assert record_path(board).read_text() == "kept\n"  # written once, with the first row
        before = board.read_text()

        def full(descriptor):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr("aaai.scoring.scoreboard.os.fsync", full)
        with pytest.raises(ConfigError) as caught:
            scores.append({**row, "seed": 3})
        monkeypatch.undo()
        assert board.read_text() == before  # the row that could not be made durable is gone
        assert str(caught.value) == (
            f"--out: cannot write {str(board)!r}: No space left on device. The 2 row(s) of {str(board)!r} "
            "written before stay; free the space or fix the permission, then run the same command again to resume"
        )
        scores.append({**row, "seed": 4})  # the next row opens the file again, without a second header
    assert [line.split(",")[3] for line in board.read_text().splitlines()[1:]] == ["1", "2", "4"]
    assert board.read_text().count("level,") == 1
    with Scoreboard(board, {"policy": "p"}, COLUMNS, []) as scores:
        pass  # closing one that wrote nothing
    assert scores.handle is None


def test_a_write_error_names_the_rename_target_when_there_is_one(tmp_path):
    from aaai.scoring.evaluation import write_error

    error = OSError(13, "Permission denied", "from.tmp", None, "to.csv")
    assert write_error(tmp_path / "b.csv", error, 0).startswith(
        "--out: cannot write 'to.csv': Permission denied. The 0"
    )
    assert write_error(tmp_path / "b.csv", OSError(13, "Permission denied", "x.csv"), 1).startswith(
        "--out: cannot write 'x.csv'"
    )
    assert f"cannot write {str(tmp_path / 'b.csv')!r}: boom" in write_error(tmp_path / "b.csv", OSError("boom"), 1)


def test_the_record_holds_the_whole_environment_and_names_each_difference(tmp_path):
    """Guards the scoreboard's refusal to mix: the record keeps the environment config (without the
    level and difficulty, which each row names), its digest, the action mode and the version, and
    resuming under anything else names every key that differs, with both values."""
    import hashlib
    import json

    from aaai import __version__
    from aaai.scoring.evaluation import check_record, env_record, record_differences, record_path

    config = load_config({"sensors": {"ray_length": 10.0}}, level=3)
    record = env_record(config)
    assert set(record) == {"env_config", "env_config_sha256", "action_mode", "aaai_version"}
    assert "level" not in record["env_config"] and "difficulty" not in record["env_config"]
    assert "curriculum" not in record["env_config"] and record["env_config"]["sensors"]["ray_length"] == 10.0
    assert (
        record["env_config_sha256"]
        == hashlib.sha256(json.dumps(record["env_config"], sort_keys=True).encode()).hexdigest()
    )
    assert record["action_mode"] == "rotation" and record["aaai_version"] == __version__
    assert env_record(load_config({"sensors": {"ray_length": 10.0}}, level=5)) == record
    other = env_record(load_config({"sensors": {"ray_length": 15.0}}))
    assert other["env_config_sha256"] != record["env_config_sha256"]
    assert record_differences({"a": {"b": 1}, "c": 2}, {"a": {"b": 3}, "d": 4}) == [
        "a.b: 1 there, 3 now",
        "c: 2 there, 'absent' now",
        "d: 'absent' there, 4 now",
    ]
    assert record_differences("not a record", {"a": 1}) == ["a: 'absent' there, 1 now"]
    assert record_differences({"a": None}, {}) == ["a: None there, 'absent' now"]

    board = tmp_path / "board.csv"
    check_record(board, {"policy": "p"})  # no scoreboard: nothing to refuse
    board.write_text("level\n")
    check_record(board, {"policy": "p"})  # a header alone: no rows to mix with
    board.write_text("level\n0\n")
    with pytest.raises(ConfigError, match=r"holds episodes of an unknown policy \(no board_scored_with.json\)"):
        check_record(board, {"policy": "p"})
    record_path(board).write_text(json.dumps({"policy": "p", "seeds": "list"}))
    check_record(board, {"policy": "p", "seeds": "list"})
    with pytest.raises(ConfigError) as caught:
        check_record(board, {"policy": "q", "seeds": "list"})
    assert "differ in 1 key(s): policy: 'p' there, 'q' now. Choose another --out, or delete board.csv" in str(
        caught.value
    )
    record_path(board).write_text("{not json")
    with pytest.raises(ConfigError, match="differ in 1 key"):
        check_record(board, {"policy": "p"})
    record_path(board).write_text("[]")
    with pytest.raises(ConfigError, match="its record cannot be read"):
        check_record(board, {})


@pytest.mark.parametrize("mode", ["train", "1,2"])
def test_a_seed_key_goes_only_with_the_reserved_seeds(mode):
    from aaai.scoring.evaluation import seeds_for

    with pytest.raises(ConfigError, match=rf"--seeds: got '{mode}' with a seed key; allowed: a seed key only with"):
        seeds_for(mode, 0, 0, 3, key="secret")
    assert seeds_for("reserved", 0, 0, 3, key="secret") != seeds_for("reserved", 0, 0, 3)


def test_the_seed_lists_each_mode_gives():
    """Guards `--seeds`: train gives fixed, distinct draws from the training range per cell; a list
    is taken as written; anything else is refused naming what is allowed."""
    from aaai.scoring.evaluation import seeds_for

    train = seeds_for("train", 2, 1, 50)
    assert len(train) == 50 == len(set(train)) and all(seed_range(s) is TRAIN_SEEDS for s in train)
    assert all(isinstance(s, int) for s in train) and train == seeds_for("train", 2, 1, 50)
    assert train != seeds_for("train", 2, 2, 50)
    assert max(train) > TRAIN_SEEDS.stop // 2  # drawn from the whole range
    assert seeds_for("7,3,7", 0, 0, 99) == [7, 3, 7]
    assert seeds_for("reserved", 1, 0, 4) == reserved_seeds(1, 0, 4)
    with pytest.raises(ConfigError, match=r"--seeds: got 'some'; allowed: reserved, train or a list like 1,2,3"):
        seeds_for("some", 0, 0, 1)
    with pytest.raises(ConfigError, match="got '1;2'"):
        seeds_for("1;2", 0, 0, 1)


def test_the_summary_per_level_per_arena_and_per_category(tmp_path):
    """Guards the summary a scoreboard prints: per level in level order then overall; per arena,
    per category (in level order, the uncategorised last) then overall; and its markdown table."""
    import math

    from aaai.scoring.evaluation import summarise, summarise_arenas, summary_markdown, write_summary

    rows = [_row(3, "failed", 0.1, 0.2), _row(0, "succeeded", 1.0, 1.0), _row(3, "passed", 0.9, 0.8)]
    summary = summarise(rows)
    assert [s["level"] for s in summary] == ["L0 food_only", "L3 avoidance", "overall"]
    assert [s["episodes"] for s in summary] == [1, 2, 3]
    assert summary[1]["mean_ratio"] == pytest.approx(0.5) and summary[1]["passed_pct"] == 50.0
    nan = summarise([{**_row(0, "failed", "nan"), "ratio": "nan"}])[-1]
    assert math.isnan(nan["mean_ratio"])
    table = summary_markdown(summary).splitlines()
    assert table[0] == "| level | episodes | mean return | mean ratio | passed or better | succeeded |"
    assert table[1] == "|---|---:|---:|---:|---:|---:|"
    assert table[3] == "| L3 avoidance | 2 | 0.500 | 0.500 | 50% | 0% |"
    assert summary_markdown(summary).endswith("| overall | 3 | 0.667 | 0.667 | 67% | 33% |\n")
    path = write_summary(summary, tmp_path / "board.csv")
    assert path == tmp_path / "board_summary.md" and path.read_text() == summary_markdown(summary)

    arena_rows = [
        {**_row(0, "failed", 0.0), "arena": "b.yaml"},
        {**_row(0, "passed", 0.9, 0.9), "arena": "a.yaml"},
        {**_row(0, "succeeded", 1.0, 1.0), "arena": "a.yaml"},
        {**_row(0, "failed", 0.0), "arena": "c.yaml"},
    ]
    categories = {"a.yaml": "avoidance", "b.yaml": "food_contact", "c.yaml": None}
    by = {s["level"]: s for s in summarise_arenas(arena_rows, categories)}
    assert list(by) == [
        "arena a.yaml",
        "arena b.yaml",
        "arena c.yaml",
        "category L0 food_contact",
        "category L4 avoidance",
        "category uncategorised",
        "overall",
    ]
    assert by["arena a.yaml"]["episodes"] == 2 and by["arena a.yaml"]["succeeded_pct"] == 50.0
    assert by["category L4 avoidance"]["passed_pct"] == 100.0 and by["overall"]["episodes"] == 4
    assert "category mine" in [s["level"] for s in summarise_arenas(arena_rows, {"a.yaml": "mine"})]


# --- the one scoring loop: levels, arenas, hooks ---------------------------------------------
ARENAS = config_dir() / "arenas"  # the shipped battery (found from a copy of the tests too)
SHORT = load_config(None, max_steps=10)


def test_an_arena_battery_is_scored_file_by_seed_and_resumed(tmp_path):
    """Guards `aaai eval --arenas`: one row per (arena, seed) in file then seed order, its arena
    column the file's name; a re-run plays only what is missing."""
    from aaai.scoring.evaluation import evaluate_arenas, scored_episodes

    first, second = sorted(ARENAS.glob("*.yaml"))[:2]
    out = tmp_path / "board.csv"
    seen = []
    rows = evaluate_arenas("random", [first, second], [1, 0], out, SHORT, on_episode=seen.append)
    assert [(r["arena"], r["seed"]) for r in rows] == [
        (first.name, "1"),
        (first.name, "0"),
        (second.name, "1"),
        (second.name, "0"),
    ]
    assert [(r["arena"], r["seed"]) for r in seen] == [
        (first.name, 1),
        (first.name, 0),
        (second.name, 1),
        (second.name, 0),
    ]
    assert rows == scored_episodes(out) and int(rows[0]["max_steps"]) == 10
    lines = out.read_text().splitlines()
    out.write_text("\n".join(lines[:2]) + "\n")  # only the first row kept
    again = evaluate_arenas("random", [first, second], [1, 0], out, SHORT)
    assert [(r["arena"], r["seed"]) for r in again] == [(r["arena"], r["seed"]) for r in rows]
    assert [{k: v for k, v in r.items() if k != "wall_seconds"} for r in again] == [
        {k: v for k, v in r.items() if k != "wall_seconds"} for r in rows
    ]


def test_an_arena_battery_is_refused_before_any_episode(tmp_path):
    import json

    from aaai.scoring.evaluation import LEGACY_COLUMNS, env_record, evaluate_arenas, record_path

    arena = sorted(ARENAS.glob("*.yaml"))[0]
    twin = tmp_path / "twin" / arena.name
    twin.parent.mkdir()
    twin.write_text(arena.read_text())
    out = tmp_path / "board.csv"
    with pytest.raises(ConfigError, match=rf"--arenas: two arena files share a name \({arena.name}\)"):
        evaluate_arenas("random", [arena, twin], [0], out, SHORT)
    broken = tmp_path / "broken.yaml"
    broken.write_text("nonsense: [\n")
    with pytest.raises(ConfigError, match="broken.yaml"):
        evaluate_arenas("random", [arena, broken], [0], out, SHORT)
    assert not out.exists()
    out.write_text(",".join(LEGACY_COLUMNS) + "\n" + ",".join(["0"] * len(LEGACY_COLUMNS)) + "\n")
    record_path(out).write_text(json.dumps(env_record(SHORT)))  # scored with the same (empty) record
    with pytest.raises(ConfigError, match=r"--out: '.*board.csv' is an older scoreboard without an arena column"):
        evaluate_arenas("random", [arena], [0], out, SHORT, record={})


def test_the_loop_plays_what_the_hooks_make_and_reports_each_row(tmp_path):
    """Guards evaluate's hooks (a human's policy in aaai play, a recorder for --save-replays): the
    policy make_policy builds, once, on the scoring environment, which has no reward shaping."""
    from aaai.scoring.evaluation import evaluate

    shapings, steps, rows = [], [], []

    def make_policy(env):
        shapings.append(env.config.episode.shaping)
        space = env.action_space

        def act(observation):
            steps.append(1)
            return np.zeros(space.shape, space.dtype)

        return act

    config = load_config({"train": {"reward_shaping": 1.0}}, max_steps=10)
    out = evaluate("random", [Cell(0, 0, [2, 1])], tmp_path / "b.csv", config, rows.append, make_policy=make_policy)
    assert shapings == [0.0] and len(steps) == sum(int(r["steps"]) for r in out) == 20
    assert [r["seed"] for r in rows] == [2, 1] and [r["seed"] for r in out] == ["2", "1"]


@pytest.mark.parametrize(
    "ratio, episode_return, pass_mark, expected",
    [
        (0.1, 2.0, 2.0, "passed"),  # at the arena's own mark: passes whatever the ratio
        (0.1, 1.999, 2.0, "failed"),
        (0.95, 1.999, 2.0, "failed"),  # below it: fails whatever the ratio
        (1.0, 2.0, 2.0, "succeeded"),
        (0.999, 3.0, 2.0, "passed"),
        (0.5, None, 2.0, "failed"),  # no return given: the ratio decides
        (0.85, None, 2.0, "passed"),
    ],
)
def test_an_arenas_own_pass_mark_decides_at_its_boundary(ratio, episode_return, pass_mark, expected):
    assert outcome(ratio, episode_return, pass_mark) == expected


def test_a_row_is_the_episode_of_its_cell_scored_against_its_best_reward(tmp_path):
    """Guards the row: the episode is the cell's (level, difficulty, seed), as the environment plays
    it, and its ratio is the return over the level instance's best reward."""
    from aaai.env import AnimalAIEnv
    from aaai.scoring.episodes import play
    from aaai.scoring.evaluation import evaluate
    from aaai.scoring.policies import RandomPolicy

    config = load_config(None, max_steps=30)
    row = evaluate("random", [Cell(4, 2, [11])], tmp_path / "b.csv", config)[0]
    env = AnimalAIEnv(config=config, shaping=0.0)
    try:
        result = play(env, RandomPolicy(env), 11, options={"level": 4, "difficulty": 2})
    finally:
        env.close()
    best = result.info["max_reward"]
    assert (row["level"], row["level_name"], row["difficulty"], row["seed"]) == ("4", "avoidance", "2", "11")
    assert float(row["return"]) == round(result.episode_return, 6) and float(row["max_reward"]) == round(best, 6)
    assert float(row["ratio"]) == round(result.episode_return / best, 6)
    assert row["outcome"] == outcome(result.episode_return / best)
    assert int(row["steps"]) == result.info["steps"] and row["max_steps"] == "30" and row["arena"] == ""


def test_an_arena_row_is_its_files_level_and_its_own_pass_mark_decides(tmp_path):
    from aaai.scoring.evaluation import evaluate_arenas
    from aaai.task.arena import load_arena

    source = next(p for p in sorted(ARENAS.glob("*.yaml")) if load_arena(p, 0).level != 0)
    battery = []
    for name, mark in (("easy.yaml", "-1000"), ("hard.yaml", "1000"), ("plain.yaml", None)):
        battery.append(tmp_path / name)
        battery[-1].write_text(source.read_text() + (f"\npass_mark: {mark}\n" if mark else ""))
    rows = evaluate_arenas("random", battery, [0], tmp_path / "b.csv", SHORT)
    spec = load_arena(source, 0)
    assert {(r["level"], r["difficulty"]) for r in rows} == {(str(spec.level), str(spec.difficulty))}
    assert {r["arena"]: r["outcome"] for r in rows} == {
        "easy.yaml": "passed",
        "hard.yaml": "failed",
        "plain.yaml": "failed",
    }
