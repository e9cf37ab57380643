"""``aaai compare``: two scoreboards of the same episodes, level by level, with intervals; or two
recipes, each trained several times, by their runs' spread."""

from __future__ import annotations

import click

from aaai.config import ConfigError

from .options import Output

BOARD = click.Path(exists=True, dir_okay=False)


@click.command("compare")
@click.argument("base", type=BOARD)
@click.argument("other", type=BOARD)
@click.option(
    "--base-run", "base_runs", type=BOARD, multiple=True,
    help="Another training run of BASE's recipe (its scoreboard; repeat for more). With runs on both "
    "sides, the table compares the recipes over their runs.",
)  # fmt: skip
@click.option("--other-run", "other_runs", type=BOARD, multiple=True, help="Another training run of OTHER's recipe.")
@click.option("--out", "output", type=Output(dir_okay=False), help="Also write the table to this markdown file.")
def compare_command(base, other, base_runs, other_runs, output):
    """Compare the scoreboard OTHER with BASE (e.g. a fine-tuned student with baselines/student.csv)
    on the episodes both hold: per level, each pass rate with its 95 % Wilson interval, the difference
    with its 95 % interval (Newcombe) and whether OTHER is better, worse or not shown to differ. Each
    is named by its file (a run's scoreboard_*.csv by its run folder).

    These intervals count the episodes' chance: they compare two models. To compare two recipes (two
    configs, each trained with several seeds or on several machines), give each side's other runs
    with --base-run and --other-run: per level, every run's pass rate, each side's mean, and the
    difference of the means with Welch's 95 % interval over the runs (2 or more runs a side)."""
    from aaai.files import write_atomic
    from aaai.tools.compare import (
        board_name,
        compare,
        compare_runs,
        comparison_markdown,
        read_scoreboard,
        runs_markdown,
    )

    try:
        if base_runs or other_runs:
            bases, others = [base, *base_runs], [other, *other_runs]
            lines = compare_runs([read_scoreboard(b) for b in bases], [read_scoreboard(o) for o in others])
            table = runs_markdown(lines, [board_name(b) for b in bases], [board_name(o) for o in others])
        else:
            table = comparison_markdown(
                compare(read_scoreboard(base), read_scoreboard(other)), board_name(base), board_name(other)
            )
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    click.echo(table, nl=False)
    if output:
        write_atomic(output, table)
        click.echo(f"written: {output}")
