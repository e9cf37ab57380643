"""``aaai baselines``: random, the reference and trained runs scored on every reserved cell."""

from __future__ import annotations

import re
from pathlib import Path

import click

from aaai.config import ConfigError

from .options import WORKERS, Output, parse_levels, parse_range, rule


@click.command("baselines")
@click.option(
    "--demo-run",
    type=click.Path(file_okay=False),
    default="runs/demo",
    show_default=True,
    help="The trained run scored as ppo_demo (make demo writes it).",
)
@click.option("--out", "folder", type=Output(file_okay=False), default="baselines", show_default=True)
@click.option(
    "--levels", default="all", show_default=True, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b,L3', or all."
)
@click.option("--difficulty", default="0-10", show_default=True)
@click.option("--seeds-per-cell", "-k", "count", type=rule("eval.seeds_per_cell"), default=10, show_default=True)
@click.option("--workers", type=WORKERS, default=2, show_default=True, help="Worker processes.")
@click.option(
    "--student-run",
    type=click.Path(file_okay=False),
    help="A student of the reference (aaai train --teacher reference), scored as student.",
)
@click.option("--ppo-gait-run", type=click.Path(file_okay=False), help="A PPO run in gait mode, scored as ppo_gait.")
@click.option(
    "--learned",
    "more",
    multiple=True,
    metavar="NAME=RUN",
    help="Another trained run, scored as NAME (a-z, 0-9 and _; e.g. student_lstm=runs/student_lstm); repeatable.",
)
@click.option(
    "--only",
    help="Score only these policies (e.g. 'student,ppo_gait'); the table and heatmap still "
    "show every scoreboard already in --out.",
)
def baselines_command(demo_run, folder, levels, difficulty, count, workers, student_run, ppo_gait_run, more, only):
    """Score random actions, the reference controller and trained runs on the reserved seeds of
    every cell: a scoreboard each, a pass-rate table and a heatmap (make baselines)."""
    from aaai.scoring.runs import check_writable
    from aaai.tools.baselines import policies, run

    try:
        check_writable(Path(folder), "--out", folder=True)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    learned = {name: Path(path) for name, path in (("student", student_run), ("ppo_gait", ppo_gait_run)) if path}
    for name, path in learned.items():
        if not path.is_dir():
            raise click.UsageError(f"--{name.replace('_', '-')}-run: got {str(path)!r}, which is not a run folder")
    for given in more:
        name, _, path = given.partition("=")
        if (
            not re.fullmatch(r"[a-z0-9_]{1,40}", name)
            or not path
            or name in ("random", "reference", "ppo_demo", *learned)
        ):
            raise click.UsageError(
                f"--learned: got {given!r}; allowed: NAME=RUN, NAME of 1-40 of a-z, 0-9 and _, not random, "
                "reference, ppo_demo or a name given twice"
            )
        if not Path(path).is_dir():
            raise click.UsageError(f"--learned: got {given!r}; {path!r} is not a run folder")
        learned[name] = Path(path)
    chosen = [name.strip() for name in only.split(",")] if only else None
    needs_demo = chosen is None or "ppo_demo" in chosen
    if needs_demo and not Path(demo_run).is_dir():
        raise click.UsageError(f"--demo-run: got {demo_run!r}, which is not a run folder; run `make demo` first")
    known = ["random", "reference", "ppo_demo", *learned]
    if chosen is not None and (not chosen or any(name not in known for name in chosen)):
        raise click.UsageError(f"--only: got {only!r}; allowed: a list of {', '.join(known)}")
    level_list, difficulties = parse_levels(levels), parse_range(difficulty, "--difficulty", 0, 10)
    try:  # each policy read once, here: a damaged model is refused before any work
        named = policies(Path(demo_run) if needs_demo else None, learned, chosen)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    run(Path(folder), named, level_list, difficulties, count, workers, echo=click.echo)
