"""The ``aaai`` command group: each command lives in its own module and is registered here."""

from __future__ import annotations

import click

from .baselines import baselines_command
from .bench import bench_command
from .compare import compare_command
from .demos import demos_command
from .diagnose import diagnose_command
from .eval import eval_command
from .experiment import experiment_group
from .import_animalai import import_animalai_command
from .levels import levels_command
from .play import play
from .plot import plot_command
from .run import run_command
from .seeds import seeds_command
from .show import show
from .spec import spec_command
from .study import study
from .train import train_command
from .validate import validate


@click.group()
@click.version_option(package_name="aaai")
def cli() -> None:
    """Articulated Animal AI: a quadruped finding food in seeded cognition test levels."""


for command in (
    levels_command,
    spec_command,
    run_command,
    train_command,
    eval_command,
    demos_command,
    diagnose_command,
    baselines_command,
    compare_command,
    seeds_command,
    bench_command,
    plot_command,
    experiment_group,
    import_animalai_command,
    play,
    show,
    study,
    validate,
):
    cli.add_command(command)

if __name__ == "__main__":
    cli()
