"""``aaai spec``: the level spec a (level, difficulty, seed) generates, and its hash."""

from __future__ import annotations

import click
import numpy as np

from aaai.config import ConfigError
from aaai.levels import generate, get_level

from .options import DIFFICULTY, SEED


@click.command("spec")
@click.argument("level")
@click.option("-d", "--difficulty", type=DIFFICULTY, default=0, show_default=True)
@click.option("-s", "--seed", type=SEED, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print the whole spec as JSON.")
@click.option(
    "--yaml",
    "as_yaml",
    is_flag=True,
    help="Print the spec as an arena file (aaai.task.arena), to edit into a test of your own. The file is "
    "fixed (every episode of it starts alike) until you put randomisation forms in it.",
)
def spec_command(level, difficulty, seed, as_json, as_yaml):
    """Print the level spec that (LEVEL, difficulty, seed) generates, and its hash."""
    try:
        spec = generate(get_level(level).id, difficulty, seed)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    if as_json and as_yaml:
        raise click.UsageError("--json and --yaml: choose one")
    if as_yaml:
        from aaai.task.arena import spec_to_arena

        click.echo(spec_to_arena(spec), nl=False)
        return
    if as_json:
        click.echo(spec.to_json())
        return
    click.echo(f"{get_level(spec.level).label} {spec.name}  difficulty {spec.difficulty}  seed {spec.seed}")
    click.echo(f"agent at ({spec.agent.x:.2f}, {spec.agent.y:.2f}) heading {np.degrees(spec.agent.yaw):.0f} deg")
    for obj in spec.objects:
        x, y, z = obj.position
        moving = f"  {obj.behaviour['type']}" if obj.behaviour else ""
        click.echo(
            f"  {obj.kind:<16} {obj.shape:<8} at ({x:6.2f}, {y:6.2f}, {z:5.2f}) "
            f"size {' x '.join(f'{v:.2f}' for v in obj.size)}{moving}"
        )
    click.echo(f"max food reward {spec.max_food_reward:.3f}   hash {spec.digest()}")
