"""The statistics of the curricula experiment: the power analysis that sized it (`aaai experiment
power`), and the intervals and tests its table reports (`aaai experiment report`), on a known case."""

import csv
import math

import numpy as np
import pytest
from conftest import aaai_here

from aaai.config import load_config
from aaai.train import power
from aaai.train.experiments import plan


# --- power ------------------------------------------------------------------------------------
@pytest.mark.parametrize(("effect", "seeds"), [(1.0, 17), (0.5, 64), (2.0, 6)])
def test_seeds_needed_match_the_t_test_tables(effect, seeds):
    # two-sided two-sample t test, alpha 0.05, power 0.8 (Cohen's tables; G*Power gives the same)
    assert power.seeds_needed(effect, 1.0) == seeds
    assert power.t_test_power(seeds, effect) >= 0.8 > power.t_test_power(seeds - 1, effect)


def test_seeds_needed_approach_the_normal_closed_form_when_many():
    # 2 (z_0.975 + z_0.8)^2 / d^2 = 15.70 / d^2; the t test needs about one more per group
    assert power.normal_seeds(0.2, 1.0) == pytest.approx(2 * (1.959964 + 0.841621) ** 2 / 0.04, rel=1e-5)
    assert power.seeds_needed(0.2, 1.0) - power.normal_seeds(0.2, 1.0) == pytest.approx(1.0, abs=1.0)
    assert power.t_test_power(17, power.detectable(17, 1.0)) == pytest.approx(0.8, abs=1e-6)


def write_experiment(folder, rates, k=10, cells=((0, 0), (0, 1))):
    """An experiment folder whose runs passed ``rates[sampler][i]`` of k episodes in every cell."""
    experiment = plan(
        folder,
        list(rates),
        list(range(max(len(v) for v in rates.values()))),
        load_config(None, levels=[0], difficulties=[d for _, d in cells]),
        k,
    )
    for sampler, passes in rates.items():
        for seed, passed in enumerate(passes):
            run = experiment.run_dir(sampler, seed)
            run.mkdir(parents=True)
            with open(run / "scoreboard_reserved.csv", "w", newline="") as handle:
                writer = csv.writer(handle)
                writer.writerow(["level", "difficulty", "seed", "return", "outcome"])
                for level, difficulty in cells:
                    for i in range(k):
                        writer.writerow([level, difficulty, i, 1.0, "succeeded" if i < passed else "failed"])
    return experiment


def test_variance_splits_into_the_seed_and_the_binomial_part(tmp_path):
    write_experiment(tmp_path, {"paper": [2, 4], "uniform": [5, 5, 8]}, k=10)  # 20 %, 40 % ...
    aaai_here("experiment", "report", tmp_path)
    v = power.variance(tmp_path)
    # pooled over samplers: paper's rates 20, 40 (var 200, 1 df), uniform's 50, 50, 80 (var 300, 2 df)
    assert v.observed == pytest.approx((200 * 1 + 300 * 2) / 3)
    # a run passing p of 10 in each of 2 cells: p (1 - p) 10/9 / 10 per cell, / 2 for the mean of 2 cells
    per_run = [1e4 * p * (1 - p) / 9 / 2 for p in (0.2, 0.4, 0.5, 0.5, 0.8)]
    assert v.stratified and v.binomial == pytest.approx(np.mean(per_run))
    assert v.sd(40) == pytest.approx(math.sqrt(v.observed - v.binomial + v.binomial / 4))


# --- the table's intervals and tests ------------------------------------------------------------
def read(path):
    with open(path, newline="") as handle:
        return {row["sampler"]: row for row in csv.DictReader(handle)}


def test_the_table_gives_welchs_t_anova_and_intervals_and_says_a_partial_experiment(tmp_path):
    rates = {"paper": [1, 2, 3], "uniform": [4, 6, 8, 9], "plr": [5, 9, 7]}  # passes of 10 per cell
    write_experiment(tmp_path, rates)
    (tmp_path / "plr-seed2" / "scoreboard_reserved.csv").unlink()  # plr's third run not scored yet
    shown = aaai_here("experiment", "report", tmp_path).stdout
    assert "Under way: 9 of 12 runs scored" in shown  # 4 seeds each are planned; paper and plr have 3, 2
    table = read(tmp_path / "table.csv")
    plr, uniform = np.array([50.0, 90.0]), np.array([40.0, 60.0, 80.0, 90.0])
    se = math.sqrt(plr.var(ddof=1) / 2 + uniform.var(ddof=1) / 4)
    assert float(table["plr"]["welch_t_vs_uniform"]) == pytest.approx((plr.mean() - uniform.mean()) / se, abs=1e-4)
    assert float(table["plr"]["difference_vs_uniform"]) == pytest.approx(plr.mean() - uniform.mean(), abs=1e-4)
    half = 12.7062 * plr.std(ddof=1) / math.sqrt(2)  # t_0.975 with 1 degree of freedom
    assert float(table["plr"]["reserved_pass_pct_ci95_high"]) == pytest.approx(70 + half, abs=1e-2)
    low, high = (
        float(table["paper"]["bootstrap95_low_vs_uniform"]),
        float(table["paper"]["bootstrap95_high_vs_uniform"]),
    )
    assert low < 20 - 67.5 < high < 0  # paper's 20 against uniform's 67.5: below, and surely so
    assert table["uniform"]["welch_t_vs_uniform"] == "nan"
    groups = [[10.0, 20.0, 30.0], list(uniform), list(plr)]
    grand = np.mean(np.concatenate(groups))
    between = sum(len(g) * (np.mean(g) - grand) ** 2 for g in groups) / 2
    within = sum(((np.array(g) - np.mean(g)) ** 2).sum() for g in groups) / (9 - 3)
    assert f"ANOVA F = {between / within:.2f}" in shown
    apart = [[0.0, 1, 2], [10.0, 11, 12], [20.0, 21, 22]]  # only the 3! relabellings by group reach its F
    assert power.permutation_anova(apart, resamples=2000) == pytest.approx(6 / 1680, abs=0.004)
    assert power.permutation_anova([[0.0, 5, 10], [1.0, 6, 9]], resamples=500) > 0.5
