"""``aaai plot``: the learning curves of run folders on one figure."""

from __future__ import annotations

import click

from aaai.config import ConfigError
from aaai.errors import needs_extra

from .options import MANY, Output


@click.command("plot")
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True))
@click.option(
    "--out",
    "output",
    type=Output(dir_okay=False),
    default="learning_curves.png",
    show_default=True,
    help="The PNG to write.",
)
@click.option(
    "--smooth",
    type=click.IntRange(1, MANY),
    default=50,
    show_default=True,
    help="Episodes in each point's running mean.",
)
def plot_command(runs, output, smooth):
    """Draw learning curves on one figure. RUN folders: task return and pass rate of their training
    episodes against steps. Checkpoint scoreboards (an `aaai experiment curricula` folder, or CSV
    files with step and pass_pct columns, such as a run's curve.csv): the pass rate on reserved seeds
    against decisions and against training wall time, per sampler or recipe, with a band over seeds."""
    from pathlib import Path

    from aaai.train.experiments import is_checkpoint_source, plot_checkpoints, plot_runs

    kinds = {is_checkpoint_source(Path(run)) for run in runs}
    if len(kinds) > 1:
        raise click.UsageError(
            f"RUNS: got {', '.join(runs)}: run folders and checkpoint scoreboards (experiment folders, CSV files) "
            "mixed; allowed: one kind per figure"
        )
    try:
        path = plot_checkpoints(list(runs), output) if kinds == {True} else plot_runs(list(runs), output, smooth=smooth)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai plot")) from None
    click.echo(f"learning curves of {len(runs)} source(s): {path}")
