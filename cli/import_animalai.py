"""``aaai import-animalai``: Animal-AI arena files converted into aaai arena files."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ConfigError

from .options import Finite, Output


@click.command("import-animalai")
@click.argument("source", type=click.Path())
@click.option("--out", "out", type=Output(file_okay=False), required=True, help="Folder for the arena files.")
@click.option(
    "--scale",
    type=Finite(0, 1000, min_open=True),
    default=5.0,
    show_default=True,
    help="Units here per Animal-AI unit (its arena is 40 across; our body's footprint 10).",
)
def import_animalai_command(source, out, scale):
    """Convert Animal-AI arena files (!ArenaConfig; a FILE or a DIR of them) into aaai arena files.

    Files are read as plain data within limits; nothing is written outside --out. Exits 1 when no
    arena converted or a file or name was refused (each named on a SKIPPED line)."""
    from aaai.tools.animalai import import_animalai

    try:
        results = import_animalai(Path(source), Path(out), scale, echo=click.echo)
    except (ConfigError, OSError) as error:
        raise click.UsageError(str(error)) from None
    if not any(not result.problem for result in results) or any(result.refused for result in results):
        raise SystemExit(1)  # nothing converted, or a file or name refused (each named on a SKIPPED line)
