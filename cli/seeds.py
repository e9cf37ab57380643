"""``aaai seeds``: the reserved evaluation seeds of each (level, difficulty) cell."""

from __future__ import annotations

import click

from aaai.levels import get_level

from .options import parse_levels, parse_range, rule


@click.command("seeds")
@click.option(
    "--levels", default="all", show_default=True, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b,L3', or all."
)
@click.option("--difficulty", default="0-10", show_default=True)
@click.option("-k", "--seeds-per-cell", "count", type=rule("eval.seeds_per_cell"), default=10, show_default=True)
@click.option(
    "--seed-key-file",
    type=click.Path(dir_okay=False),
    help="A file holding a secret key: print the hidden list it stands for (or set AAAI_SEED_KEY).",
)
def seeds_command(levels, difficulty, count, seed_key_file):
    """Print the reserved evaluation seeds of each (level, difficulty) cell."""
    from aaai.levels.seeds import key_record, read_seed_key, reserved_seeds

    try:
        key = read_seed_key(seed_key_file)
    except ValueError as error:
        raise click.UsageError(str(error)) from None
    click.echo(f"seed key: {key_record(key)}")
    for level in parse_levels(levels):
        for d in parse_range(difficulty, "--difficulty", 0, 10):
            seeds = reserved_seeds(level, d, count, key)
            click.echo(f"{get_level(level).label} d{d}: " + ",".join(str(s) for s in seeds))
