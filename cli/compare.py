"""``aaai compare``: two scoreboards of the same episodes, level by level, with intervals."""

from __future__ import annotations

import click

from aaai.config import ConfigError

from .options import Output


@click.command("compare")
@click.argument("base", type=click.Path(exists=True, dir_okay=False))
@click.argument("other", type=click.Path(exists=True, dir_okay=False))
@click.option("--out", "output", type=Output(dir_okay=False), help="Also write the table to this markdown file.")
def compare_command(base, other, output):
    """Compare the scoreboard OTHER with BASE (e.g. a fine-tuned student with baselines/student.csv)
    on the episodes both hold: per level, each pass rate with its 95 % Wilson interval, the difference
    with its 95 % interval (Newcombe) and whether OTHER is better, worse or not shown to differ. Each
    is named by its file (a run's scoreboard_*.csv by its run folder)."""
    from aaai.files import write_atomic
    from aaai.tools.compare import board_name, compare, comparison_markdown, read_scoreboard

    try:
        lines = compare(read_scoreboard(base), read_scoreboard(other))
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    table = comparison_markdown(lines, board_name(base), board_name(other))
    click.echo(table, nl=False)
    if output:
        write_atomic(output, table)
        click.echo(f"written: {output}")
