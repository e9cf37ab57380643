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
@click.option(
    "--report",
    type=Output(file_okay=False),
    default=None,
    help="Also check every converted file on every seed and write coverage.csv and coverage.md here.",
)
@click.option(
    "--seeds",
    type=click.IntRange(1, 100),
    default=10,
    show_default=True,
    help="With --report: check each converted file on seeds 0 to N-1.",
)
def import_animalai_command(source, out, scale, report, seeds):
    """Convert Animal-AI arena files (!ArenaConfig; a FILE or a DIR of them) into aaai arena files.

    Files are read as plain data within limits; nothing is written outside --out. Exits 1 when no
    arena converted or a file or name was refused (each named on a SKIPPED line). With --report, the
    counts by cause (converted or not and why, valid on every seed or not and why) go to
    REPORT/coverage.md and one row per arena to REPORT/coverage.csv."""
    from aaai.tools.animalai import import_animalai
    from aaai.tools.animalai_report import measure

    try:
        if report is not None:
            rows = measure(Path(source), Path(out), Path(report), seeds, echo=click.echo, scale=scale)
            click.echo(f"wrote {Path(report) / 'coverage.md'} and coverage.csv")
            if not any(row["converted"] == "yes" for row in rows):
                raise SystemExit(1)
            return
        results = import_animalai(Path(source), Path(out), scale, echo=click.echo)
    except (ConfigError, OSError) as error:
        raise click.UsageError(str(error)) from None
    if not any(not result.problem for result in results) or any(result.refused for result in results):
        raise SystemExit(1)  # nothing converted, or a file or name refused (each named on a SKIPPED line)
