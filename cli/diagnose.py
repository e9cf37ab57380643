"""``aaai diagnose``: a policy's failed episodes replayed, each sorted into a first cause."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import TEACHERS, ConfigError
from aaai.scoring.policies import resolve

from .options import MANY, POLICY_HELP, parse_levels


@click.command("diagnose")
@click.option("--policy", required=True, help=POLICY_HELP)
@click.option(
    "--scoreboard",
    type=click.Path(exists=True, dir_okay=False),
    required=True,
    help="The policy's scoreboard CSV (aaai eval): its failed episodes are replayed.",
)
@click.option("--levels", help="Only these levels, by id, label or name, e.g. '7,8' or 'L8'.")
@click.option(
    "--limit", type=click.IntRange(1, MANY), help="At most this many failed episodes per level (or arena category)."
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(),
    help="A YAML for the env (default: the environment the scoreboard's *_scored_with.json records, else the "
    "run's config); one that differs from the recorded environment is refused.",
)
@click.option(
    "--arenas",
    type=click.Path(),
    help="For a scoreboard of arena files (aaai eval --arenas, aaai baselines --battery): the folder they "
    "are in (default: the folder its *_scored_with.json names).",
)
@click.option(
    "--teacher",
    type=click.Choice(TEACHERS),
    help="Watch each replay with this teacher, as DAgger does (gait or discrete mode): adds the share of decisions the "
    "student stood where the teacher asked it to move, and turned the other way from the turn it asked for.",
)
def diagnose_command(policy, scoreboard, levels, limit, config_path, arenas, teacher):
    """Why a policy fails: its failed episodes replayed, each sorted into a first cause (fell, never
    saw food, lost sight of it, saw it but did not reach it, ate the wrong food); per level, and per
    category for arena files. With --teacher, also where a student parted from its teacher."""
    from aaai.scoring.diagnose import diagnose, scored_config, table_markdown

    try:
        chosen = resolve(policy)
        failures = diagnose(
            chosen,
            Path(scoreboard),
            scored_config(Path(scoreboard), chosen.config(config_path), config_path is not None),
            parse_levels(levels) if levels else None,
            limit,
            Path(arenas) if arenas else None,
            warn=lambda message: click.echo(message, err=True),
            teacher=teacher,
        )
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    click.echo(table_markdown(failures), nl=False)
