"""``aaai bench``: the speed and memory benchmark, its JSON and markdown report."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ConfigError, load_config, read_yaml

from .options import MANY, Output, parse_levels, rule


@click.command("bench")
@click.option("--levels", help="Levels to measure by id, label or name (default: all).")
@click.option(
    "--rounds",
    type=click.IntRange(1, 1000),
    default=5,
    show_default=True,
    help="Alternated rounds: each figure is timed once per round; ratios are medians over rounds.",
)
@click.option(
    "--steps", type=click.IntRange(100, MANY), default=1000, show_default=True, help="Steps per figure and round."
)
@click.option("--resets", type=click.IntRange(5, MANY), default=50, show_default=True, help="Resets timed per level.")
@click.option(
    "--worker-steps",
    type=click.IntRange(100, MANY),
    default=1000,
    show_default=True,
    help="Steps per worker and round in the 1/2/4-worker runs.",
)
@click.option(
    "--train-steps",
    type=rule("train.total_steps", low=0),
    default=4096,
    show_default=True,
    help="Steps per round of PPO, the random agent and the environment alone (0: no training row).",
)
@click.option("--train-envs", type=rule("train.num_envs"), help="Workers of the training row (default: the config's).")
@click.option(
    "--config",
    "config_path",
    type=click.Path(),
    help="A YAML overriding configs/default.yaml for the training row (its train and curriculum keys, senses).",
)
@click.option("--memory-steps", type=click.IntRange(1000, MANY), default=20000, show_default=True)
@click.option(
    "--out",
    "folder",
    type=Output(what="folder"),
    default="bench",
    show_default=True,
    help="Folder for bench.json and bench.md.",
)
def bench_command(
    levels, rounds, steps, resets, worker_steps, train_steps, train_envs, config_path, memory_steps, folder
):
    """Measure steps/s against a bare PyBullet loop and MuJoCo Ant-v5, training against the
    environment alone, resets, workers and memory; alternated rounds, medians and spreads."""
    from aaai.tools import bench, bench_report

    level_list = parse_levels(levels) if levels else None
    train_config: dict = {}
    if config_path is not None:
        try:
            load_config(config_path)  # checked whole first: one message naming the key and the value
            train_config = read_yaml(config_path)
        except ConfigError as error:
            raise click.BadParameter(str(error), param_hint="--config") from None
    if train_envs:
        train_config = {**train_config, "train": {**train_config.get("train", {}), "num_envs": train_envs}}
    results = bench.run(
        level_list,
        steps=steps,
        rounds=rounds,
        resets=resets,
        worker_steps=worker_steps,
        train_steps=train_steps,
        memory_steps=memory_steps,
        train_config=train_config or None,
        log=lambda text: click.echo(text, err=True),
    )
    json_path, md_path = bench_report.write(results, Path(folder))
    click.echo(bench_report.markdown(results), nl=False)
    click.echo("ratios (medians): " + ", ".join(f"{k} {v:.2f}" for k, v in results["ratios"].items()))
    click.echo(f"written: {json_path}, {md_path}")
