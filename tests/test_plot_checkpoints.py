"""`aaai plot` of checkpoint scoreboards: the pass rate on reserved seeds against decisions and wall
time, per sampler (or recipe) with a band over seeds."""

import csv

import pytest
from conftest import aaai_here

from aaai.config import load_config
from aaai.train.experiments import band_over_seeds, plan


def write_curve(run, points):
    run.mkdir(parents=True)
    with open(run / "curve.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["step", "seconds", "episodes", "passed", "pass_pct"])
        for step, seconds, pct in points:
            writer.writerow([step, seconds, 10, round(pct / 10), pct])


def test_plot_draws_an_experiments_checkpoint_scoreboards_with_a_band_over_seeds(tmp_path):
    import cv2

    experiment = plan(tmp_path / "exp", ["paper", "uniform"], [0, 1], load_config(None, levels=[0]), 2, 1)
    for sampler, shift in (("paper", 0), ("uniform", 20)):
        for seed in (0, 1):
            points = [(50_000 * i, 60.0 * i + seed, 10 * i + shift + 10 * seed) for i in (1, 2, 3)]
            write_curve(experiment.run_dir(sampler, seed), points)
    out = tmp_path / "figure.png"
    shown = aaai_here("plot", tmp_path / "exp", "--out", out).stdout
    assert str(out) in shown
    image = cv2.imread(str(out))
    assert image is not None and image.shape[1] > 1000 and image.std() > 10  # two panels, drawn
    result = aaai_here("plot", tmp_path / "exp", tmp_path / "exp" / "paper-seed0", "--out", out, check=False)
    assert result.returncode == 2 and "mixed" in result.stderr


def test_the_band_is_the_95_interval_over_seeds_on_their_common_steps():
    rows = {
        "a": [{"step": s, "seconds": s / 10, "pass_pct": p} for s, p in ((100, 10), (200, 30))],
        "b": [{"step": s, "seconds": s / 5, "pass_pct": p} for s, p in ((100, 20), (150, 30), (200, 50))],
    }
    band = band_over_seeds(rows)
    assert list(band["steps"]) == [100, 150, 200]
    assert list(band["mean"]) == pytest.approx([15, 25, 40])  # seed a interpolated to 20 at step 150
    assert list(band["seconds"]) == pytest.approx([15, 22.5, 30])
    half = 12.7062 * 7.0711 / 1.41421  # t_0.975 (1 df) x sd of (10, 20) / sqrt(2)
    assert band["high"][0] == pytest.approx(15 + half, rel=1e-3)


def test_runs_ending_a_rollout_apart_all_count_at_the_end_and_time_is_the_median():
    ends = {"a": 301_056, "b": 301_552, "c": 301_056}
    rows = {
        seed: [{"step": 150_000, "seconds": 150, "pass_pct": 20}, {"step": end, "seconds": t, "pass_pct": p}]
        for (seed, end), t, p in zip(ends.items(), (300, 310, 3000), (30, 40, 50))
    }
    band = band_over_seeds(rows)
    assert list(band["steps"]) == [150_000, 301_056, 301_552]
    assert list(band["seeds"]) == [3, 3, 3]  # a and c held at their last value to b's end
    assert band["mean"][-1] == pytest.approx(40)
    assert band["seconds"][-1] == pytest.approx(310)  # the median: c's 3,000 s (a loaded machine) moves it not
    short = band_over_seeds(
        {**rows, "d": [{"step": 100_000, "seconds": 1, "pass_pct": 0}, {"step": 200_000, "seconds": 2, "pass_pct": 0}]}
    )
    assert list(short["seeds"])[-1] == 3  # a seed ending well before the others is not carried on


def test_plot_reads_a_checkpoint_csv_with_pass_rate_as_a_fraction(tmp_path):
    board = tmp_path / "recipes.csv"
    board.write_text("mode,decisions,seconds,pass_rate\ngait,5000,7.4,0.1\ngait,10000,12.2,0.8\n")
    out = tmp_path / "r.png"
    aaai_here("plot", board, "--out", out)
    assert out.stat().st_size > 1000
    wrong = tmp_path / "no.csv"
    wrong.write_text("step,score\n1,2\n")
    result = aaai_here("plot", wrong, "--out", out, check=False)
    assert result.returncode == 2 and "pass_pct (or pass_rate)" in result.stderr
    wrong.write_text("step,pass_pct\n1,high\n")
    result = aaai_here("plot", wrong, "--out", out, check=False)
    assert result.returncode == 2 and "not a number" in result.stderr
