"""``aaai levels``: the levels and their Gymnasium ids."""

from __future__ import annotations

import click

from aaai.levels import all_levels
from aaai.registration import level_env_id


@click.command("levels")
def levels_command():
    """List the levels and their Gymnasium ids."""
    for level in all_levels().values():
        click.echo(f"{level.label:<4} {level.name:<18} {level.title:<28} {level_env_id(level)}")
