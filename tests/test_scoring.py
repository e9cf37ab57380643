"""Scoring rules a published score depends on: seed ranges, the pass mark, the summary's counts
and the episode plan both backends play. Each test says what it guards."""

from __future__ import annotations

import csv

import pytest

from aaai.config import load_config
from aaai.evaluation import Cell, episode_plan, evaluate, outcome, summarise
from aaai.seeds import RESERVED_SEEDS, TRAIN_SEEDS, reserved_seeds, seed_range, training_seed


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
