"""``aaai plot``: the learning curves of run folders on one figure."""

from __future__ import annotations

import click

from aaai.config import ConfigError
from aaai.errors import needs_extra

from .options import MANY, Output


@click.command("plot")
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False))
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
    """Draw the learning curves of RUN folders on one figure: task return and pass rate against steps."""
    from aaai.train.experiments import plot_runs

    try:
        path = plot_runs(list(runs), output, smooth=smooth)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai plot")) from None
    click.echo(f"learning curves of {len(runs)} run(s): {path}")
