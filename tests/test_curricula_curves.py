"""Learning curves on reserved seeds (`aaai experiment curricula --curve-seeds-per-cell`): every
checkpoint of a run scored once, with its training wall time, and kept when its checkpoint is deleted."""

import csv

import yaml
from conftest import aaai_here


def read(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def curricula_args(tmp_path, *extra):
    config = tmp_path / "random.yaml"
    config.write_text(
        yaml.safe_dump(
            {"episode": {"max_steps": 50}, "train": {"agent": "random", "checkpoint_every": 100, "heatmap_every": 100}}
        )
    )
    return [
        "experiment",
        "curricula",
        "--samplers",
        "paper,uniform",
        "--seeds",
        "0",
        "--steps",
        200,
        "--levels",
        0,
        "--difficulty",
        "0",
        "-k",
        1,
        "--curve-seeds-per-cell",
        1,
        "--envs",
        1,
        "--config",
        config,
        "--out",
        tmp_path / "exp",
        "--jobs",
        1,
        *extra,
    ]


def test_each_checkpoint_is_scored_on_reserved_seeds_once_and_kept_when_pruned(tmp_path):
    args = curricula_args(tmp_path)
    first = aaai_here(*args)
    folder = tmp_path / "exp"
    run = folder / "paper-seed0"
    curve = read(run / "curve.csv")
    assert [int(r["step"]) for r in curve] == [100, 200]  # a checkpoint, then the final point
    assert all(r["episodes"] == "1" for r in curve)  # one reserved seed of the one cell
    seconds = [float(r["seconds"]) for r in curve]
    assert 0 < seconds[0] <= seconds[1]  # training wall time, growing
    assert first.stdout.count("scoring the checkpoint") == 2  # one per run (the final point is the scoreboard's)
    assert len(list((run / "checkpoints").glob("step_*"))) == 2  # kept without --prune-checkpoints
    boards = sorted(p.name for p in (run / "curve").glob("reserved_*.csv"))
    assert boards == ["reserved_000000000100.csv"]
    assert (folder / "reserved_curves.png").stat().st_size > 1000  # the figure of the curves so far
    both = read(folder / "reserved_curves.csv")
    assert [(r["sampler"], r["step"]) for r in both] == [
        ("paper", "100"),
        ("paper", "200"),
        ("uniform", "100"),
        ("uniform", "200"),
    ]
    again = aaai_here(*args)
    assert "scoring" not in again.stdout and "2 point(s) scored on these 1 episodes, skipped" in again.stdout
    pruned = aaai_here(*args, "--prune-checkpoints")
    assert "scoring" not in pruned.stdout and not (run / "checkpoints").exists()  # scored, then deleted
    assert read(run / "curve.csv") == curve and read(folder / "uniform-seed0" / "curve.csv")[0]["step"] == "100"
