"""The benchmark: alternated rounds, per-round ratios, medians and spreads, and every figure in its
output (its numbers are read by people, not asserted)."""

import json
import subprocess
import sys

import pytest

from aaai.tools import bench, bench_report, rounds


def test_each_round_runs_everything_once_in_an_order_rotated_by_one():
    calls = []

    def runner(name):
        def run():
            calls.append(name)
            return float(len(calls))

        return run

    rates = rounds.alternate({name: runner(name) for name in "abc"}, rounds=4)
    assert calls == list("abcbcacababc")  # no figure is always first
    assert rates == {"a": [1.0, 6.0, 8.0, 10.0], "b": [2.0, 4.0, 9.0, 11.0], "c": [3.0, 5.0, 7.0, 12.0]}


def test_ratios_are_taken_within_a_round_and_summarised_by_median_and_spread():
    # the machine slows down by round; the env costs 0.5 of the limit in every round
    limit, env = [100.0, 40.0, 80.0, 10.0], [50.0, 20.0, 40.0, 5.0]
    assert rounds.per_round(env, limit) == [0.5] * 4
    assert rounds.per_round([5.0, 8.0], [4.0, 4.0], minus_one=True) == [0.25, 1.0]
    figure = rounds.summary([3.0, 1.0, 10.0, 2.0])
    assert (figure["median"], figure["min"], figure["max"]) == (2.5, 1.0, 10.0)
    assert figure["rounds"] == [3.0, 1.0, 10.0, 2.0]
    assert "0.50 (0.40..0.60)" == bench_report._ratio(rounds.summary([0.4, 0.5, 0.6]))
    assert "+61% (+55..+70%)" == bench_report._ratio(rounds.summary([0.55, 0.61, 0.70]), percent=True)


@pytest.mark.long  # about 15 s (every figure measured once): in make test-long
def test_bench_writes_every_figure_with_medians_spreads_and_load(tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "aaai_cli.main",
            "bench",
            "--levels",
            "0,10",
            "--rounds",
            "2",
            "--steps",
            "100",
            "--resets",
            "5",
            "--worker-steps",
            "100",
            "--train-steps",
            "0",
            "--memory-steps",
            "1000",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    results = json.loads((tmp_path / "bench.json").read_text())
    assert results["settings"]["rounds"] == 2
    assert len(results["load"]["before"]) == 3 and len(results["load"]["after"]) == 3
    level = results["levels"]["L0"]
    assert set(level["rates"]) == {
        "limit",
        "joints",
        "joints+rays",
        "joints+cam64rgb",
        "joints+cam84gray",
        bench.RAYS_TWO_THREADS,
        bench.WIDE_RAYS,
        bench.SWEEP,
        bench.SWEEP_MAP,
    }
    for figure in [*level["rates"].values(), *level["ratios"].values()]:
        assert len(figure["rounds"]) == 2 and figure["min"] <= figure["median"] <= figure["max"]
    assert level["ratios"]["joints / limit"]["rounds"] == [
        j / lim for j, lim in zip(level["rates"]["joints"]["rounds"], level["rates"]["limit"]["rounds"])
    ]
    assert set(level["reset_ms"]) == {"median", "p95"} and level["load"]["before"]
    assert set(results["workers"]["rates"]) == {"1", "2", "4", "2 in-process"}
    assert set(results["worker_groups"]["rates"]) == {"4 in-process", "2 x 4"}  # 4 environments a process
    assert {"L0 joints / limit", "L0 rays overhead", "L0 wide rays overhead", "2 workers / 1"} <= set(results["ratios"])
    assert "training" not in results  # --train-steps 0
    # only a level with missing floor casts for holes, and its cost is measured alternated too
    assert "cost of seeing holes" in results["levels"]["L10"]["ratios"]
    assert "cost of seeing holes" not in level["ratios"]
    markdown = (tmp_path / "bench.md").read_text()
    assert "| L0 |" in markdown and "| L0 |" in result.stdout and "L10 rays seeing holes" in markdown
    assert "Rays 1.0 wide (sensors.ray_width 1.0, three casts a ray), overhead over joints-only: L0 " in markdown
    assert "The sweep memory (sensors.sweep_memory 8), overhead over the same rays without it: L0 " in markdown
    assert "The sweep map (sensors.sweep_map 15), overhead over the sweep memory without it: L0 " in markdown
    assert "Load average" in markdown and "2 alternated rounds" in markdown


def test_the_training_row_sets_ppo_and_the_random_agent_against_the_environment_alone():
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    config = {
        "sensors": {"rays": False},
        "curriculum": {"levels": "0", "difficulties": "0"},
        "train": {"num_envs": 2, "vector": "sync", "n_steps": 32, "batch_size": 32, "n_epochs": 1, "net_width": 8},
    }
    row = bench.training_rates(steps=64, rounds=2, config=config)
    assert row["config"]["runs"] == "in-process" and row["config"]["num_envs"] == 2
    assert (row["config"]["n_epochs"], row["config"]["batch_size"], row["config"]["net_width"]) == (1, 32, 8)
    assert set(row["rates"]) == {"env alone, in-process", "env alone, worker processes", "random agent", "PPO"}
    assert all(len(figure["rounds"]) == 2 and figure["median"] > 0 for figure in row["rates"].values())
    rates = {name: figure["rounds"] for name, figure in row["rates"].items()}
    # the training config's own vector env (here in-process) is the reference, round by round
    assert row["ratios"]["PPO / env alone"]["rounds"] == rounds.per_round(rates["PPO"], rates["env alone, in-process"])
    best = [max(a, b) for a, b in zip(rates["env alone, in-process"], rates["env alone, worker processes"])]
    assert row["ratios"]["PPO / env alone (best)"]["rounds"] == rounds.per_round(rates["PPO"], best)
    assert "joint_velocities" in row["config"]["sensors"]  # training's extra senses, as aaai train runs
    assert set(row["load"]) == {"before", "after"}


def test_bench_config_sets_the_training_row_and_train_envs_overrides_its_workers(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from aaai_cli.main import cli

    seen = {}

    def fake_run(levels, train_config=None, **settings):
        seen.update(levels=levels, train_config=train_config)
        raise SystemExit(0)  # stop before measuring: only what reaches the bench matters here

    monkeypatch.setattr(bench, "run", fake_run)
    config = tmp_path / "fast.yaml"
    config.write_text("train:\n  n_epochs: 4\n  batch_size: 512\n  num_envs: 16\n")
    CliRunner().invoke(cli, ["bench", "--levels", "0", "--config", str(config), "--train-envs", "4"])
    assert seen["train_config"] == {"train": {"n_epochs": 4, "batch_size": 512, "num_envs": 4}}
    CliRunner().invoke(cli, ["bench", "--levels", "0", "--config", str(config)])
    assert seen["train_config"]["train"]["num_envs"] == 16


def test_bench_refuses_a_bad_config_naming_the_key_before_measuring_anything(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from aaai_cli.main import cli

    monkeypatch.setattr(bench, "run", lambda *a, **k: pytest.fail("measured with a bad config"))
    config = tmp_path / "bad.yaml"
    config.write_text("train:\n  n_epochs: 0\n")
    result = CliRunner().invoke(cli, ["bench", "--config", str(config)])
    assert result.exit_code == 2
    assert "--config" in result.output and "train.n_epochs" in result.output and "got 0" in result.output
