"""``aaai baselines``: random, the reference and trained runs scored on every reserved cell."""

from __future__ import annotations

import re
from pathlib import Path

import click
from click.core import ParameterSource

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
    help="Another trained run (a run folder or a model file), scored as NAME (a-z, 0-9 and _; e.g. "
    "student_lstm=runs/student_lstm or sfm=baselines/models/student_food_memory.zip); repeatable.",
)
@click.option(
    "--only",
    help="Score only these policies (e.g. 'student,ppo_gait'); the table and heatmap still "
    "show every scoreboard already in --out.",
)
@click.option(
    "--battery",
    type=click.Path(file_okay=False),
    help="Score the policies on an imported Animal-AI battery (the output folder of aaai import-animalai) "
    "instead of the levels: its files valid for the body on every seed, into OUT/battery/NAME.csv.",
)
@click.option(
    "--battery-seeds",
    type=click.IntRange(1, 100),
    default=1,
    show_default=True,
    help="With --battery: seeds 0..N-1 of each arena file.",
)
@click.option(
    "--body",
    type=click.Choice(["quadruped", "sphere"]),
    default="quadruped",
    show_default=True,
    help="With --battery: the body (agent.body); on the sphere the scoreboards are OUT/battery/NAME_sphere.csv.",
)
def baselines_command(
    demo_run,
    folder,
    levels,
    difficulty,
    count,
    workers,
    student_run,
    ppo_gait_run,
    more,
    only,
    battery,
    battery_seeds,
    body,
):
    """Score random actions, the reference controller and trained runs on the reserved seeds of
    every cell: a scoreboard each, a pass-rate table and a heatmap (make baselines). With --battery,
    on an imported Animal-AI battery instead: the table gains its section per category."""
    from aaai.files import InUse
    from aaai.scoring.runs import check_writable
    from aaai.tools.baselines import battery_files, policies, run, run_battery

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
        target = Path(path)
        if not target.is_dir() and not (target.suffix == ".zip" and target.is_file()):
            raise click.UsageError(f"--learned: got {given!r}; {path!r} is not a run folder or a model file (.zip)")
        learned[name] = target
    chosen = [name.strip() for name in only.split(",")] if only else None
    needs_demo = chosen is None or "ppo_demo" in chosen
    if needs_demo and not Path(demo_run).is_dir():
        raise click.UsageError(f"--demo-run: got {demo_run!r}, which is not a run folder; run `make demo` first")
    known = ["random", "reference", "ppo_demo", *learned]
    if chosen is not None and (not chosen or any(name not in known for name in chosen)):
        raise click.UsageError(f"--only: got {only!r}; allowed: a list of {', '.join(known)}")
    source = click.get_current_context().get_parameter_source
    if battery is None:
        given = [f"--{n.replace('_', '-')}" for n in ("battery_seeds", "body") if source(n) != ParameterSource.DEFAULT]
        if given:
            raise click.UsageError(f"{', '.join(given)}: allowed only with --battery DIR")
    else:
        flags = {"levels": "--levels", "difficulty": "--difficulty", "count": "--seeds-per-cell"}
        given = [flag for name, flag in flags.items() if source(name) != ParameterSource.DEFAULT]
        if given:
            raise click.UsageError(f"--battery: got {', '.join(given)} with it; allowed: --battery-seeds (arena files)")
        try:
            battery_files(Path(battery))
        except ConfigError as error:
            raise click.UsageError(str(error)) from None
    level_list, difficulties = parse_levels(levels), parse_range(difficulty, "--difficulty", 0, 10)
    try:  # each policy read once, here: a damaged model is refused before any work
        named = policies(Path(demo_run) if needs_demo else None, learned, chosen)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    if battery is None:
        run(Path(folder), named, level_list, difficulties, count, workers, echo=click.echo)
        return
    try:
        run_battery(Path(folder), named, Path(battery), battery_seeds, body, workers, echo=click.echo)
    except InUse as error:
        raise click.ClickException(str(error)) from None
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
