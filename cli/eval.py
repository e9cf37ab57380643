"""``aaai eval``: the flags parsed and the summary printed; the scoring is aaai.scoring.eval_job's."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import click

from aaai.config import ACTION_MODES, ConfigError
from aaai.errors import needs_extra
from aaai.files import InUse
from aaai.scoring.policies import BUILT_IN

from .options import (
    MANY,
    PROGRESS_HELP,
    TRUST_HELP,
    WORKERS,
    Output,
    Seconds,
    SeedList,
    parse_levels,
    parse_range,
    rule,
)
from .progress import progress_output


@click.command("eval")
@click.option(
    "--seeds",
    "seeds_mode",
    type=SeedList(),
    default="reserved",
    show_default=True,
    help="reserved, train, or a list like 1,2,3.",
)
@click.option(
    "--policy",
    default="random",
    show_default=True,
    help=f"A run folder, a model .zip, {', '.join(BUILT_IN)}, or module:callable (called with the env).",
)
@click.option(
    "--levels",
    help="Levels to score by id, label or name, e.g. '0-3' or 'L2b' (default: the run's or config's curriculum).",
)
@click.option("--difficulty", help="Difficulties to score (default: the curriculum's).")
@click.option(
    "--seeds-per-cell", "-k", type=rule("eval.seeds_per_cell"), help="K seeds per cell (default: eval.seeds_per_cell)."
)
@click.option("--config", "config_path", type=click.Path(), help="A YAML for the env (default: the run's config).")
@click.option(
    "--out", "output", type=Output(what="file"), help="Scoreboard CSV (default: scoreboard_<seeds>.csv in the run)."
)
@click.option(
    "--seed-key-file",
    type=click.Path(dir_okay=False),
    help="A file holding a secret key: score the hidden reserved list it stands for "
    "(or set AAAI_SEED_KEY). The scoreboard records a hash of the key, never the key.",
)
@click.option(
    "--backend",
    type=click.Choice(["local", "ray"]),
    default="local",
    show_default=True,
    help="local: one process; ray: episodes as Ray tasks (the ray extra), here or on a cluster.",
)
@click.option(
    "--address",
    help="With --backend ray: join the cluster whose head is at this address "
    "(host:port, or auto); without it a local Ray is started for the eval.",
)
@click.option(
    "--workers",
    type=WORKERS,
    default=2,
    show_default=True,
    help="With --backend ray and no --address: CPUs of the local Ray.",
)
@click.option(
    "--arenas",
    type=click.Path(exists=True),
    help="Score a battery of arena files (a folder of *.yaml, or one file) instead of levels: seeds "
    "0..K-1 (-k, default eval.seeds_per_cell) or --seeds 1,2,3; a summary per arena and per category. "
    "The scoreboard records each file's SHA-256: resuming it after a file has changed is refused.",
)
@click.option(
    "--action-mode",
    type=click.Choice(ACTION_MODES),
    help="Score in this action mode (default: the run's or config's). A model is scored only in the "
    "mode it was trained in.",
)
@click.option(
    "--study",
    "study_file",
    type=click.Path(dir_okay=False),
    help="Score exactly a study file's battery (its trials, practice left out), for `aaai study report`.",
)
@click.option("--trust-model", is_flag=True, help=TRUST_HELP)
@click.option("--progress-every", type=Seconds(0.1), default=30.0, show_default=True, help=PROGRESS_HELP)
@click.option(
    "--save-replays",
    type=Output(file_okay=False),
    help="Save each scored episode's replay (JSON: level, seed, config, actions) in this folder, for "
    "aaai run --replay and aaai show --replay (--backend local only).",
)
@click.option(
    "--checkpoints",
    is_flag=True,
    help="A learning curve: score each checkpoint of the --policy run and its final model on the same "
    "reserved episodes (--levels, --difficulty, -k); writes RUN/curve.csv for aaai plot. Resumes.",
)
@click.option(
    "--checkpoint-every",
    type=click.IntRange(1, MANY),
    help="With --checkpoints: only the first checkpoint at or past each multiple of this many steps.",
)
def eval_command(
    seeds_mode,
    policy,
    levels,
    difficulty,
    seeds_per_cell,
    config_path,
    output,
    seed_key_file,
    backend,
    address,
    workers,
    arenas,
    action_mode,
    study_file,
    trust_model,
    progress_every,
    save_replays,
    checkpoints,
    checkpoint_every,
):
    """Score a policy on fixed seeds: a CSV row per episode and a summary per level."""
    from aaai.jobs import one_thread
    from aaai.scoring.eval_job import check_options, score_policy
    from aaai.scoring.evaluation import summary_markdown

    one_thread()  # one episode at a time: a small network gains nothing from more torch threads
    if checkpoints or checkpoint_every:
        _curve(policy, levels, difficulty, seeds_per_cell, config_path, checkpoint_every, trust_model, progress_every)
        return
    try:  # refused before any work, and before the levels are read
        check_options(arenas, levels, difficulty, seed_key_file, backend, save_replays)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    battery = _study_battery(study_file, seed_key_file, seeds_per_cell, backend) if study_file else None
    with _refusals():
        result = score_policy(
            policy,
            seeds=seeds_mode,
            levels=parse_levels(levels) if levels else None,
            difficulties=parse_range(difficulty, "--difficulty", 0, 10) if difficulty else None,
            seeds_per_cell=seeds_per_cell,
            config_path=config_path,
            output=output,
            seed_key_file=seed_key_file,
            arenas=arenas,
            backend=backend,
            address=address,
            workers=workers,
            action_mode=action_mode,
            trust_model=trust_model,
            save_replays=save_replays,
            progress_every=progress_every,
            display=progress_output,
            battery=battery,
            warn=lambda message: click.echo(message, err=True),
        )
    try:
        summary_path = result.write_summary()
    except OSError as error:  # the summary is printed anyway
        click.echo(summary_markdown(result.summary), nl=False)
        where = getattr(error, "filename", None) or result.output.with_name(result.output.stem + "_summary.md")
        raise click.ClickException(
            f"cannot write the summary {str(where)!r}: {error.strerror or error}; the "
            f"scoreboard {str(result.output)!r} is whole, and the summary is printed above"
        ) from None
    click.echo(summary_markdown(result.summary), nl=False)
    click.echo(f"scoreboard {result.output} ({len(result.rows)} episodes); summary {summary_path}")


@contextmanager
def _refusals() -> Iterator[None]:
    """What scoring refuses, as one line: another process at the output (its pid named), an input not
    allowed, an output that became unwritable midway (its rows so far stay), a missing extra."""
    try:
        yield
    except InUse as error:
        raise click.ClickException(str(error)) from None
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except OSError as error:
        raise click.ClickException(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai eval")) from None


def _curve(policy, levels, difficulty, seeds_per_cell, config_path, every, trust_model, progress_every) -> None:
    """``--checkpoints``: the run's learning curve on reserved seeds; the options that choose other
    episodes or outputs refused."""
    from aaai.scoring.eval_job import score_checkpoints

    context = click.get_current_context()
    if not context.params["checkpoints"]:
        raise click.UsageError(f"--checkpoint-every: got {every}; allowed: only with --checkpoints")
    changed = {
        "seeds_mode": "--seeds",
        "output": "--out",
        "seed_key_file": "--seed-key-file",
        "backend": "--backend",
        "address": "--address",
        "arenas": "--arenas",
        "action_mode": "--action-mode",
        "study_file": "--study",
        "save_replays": "--save-replays",
    }
    clashes = [
        flag
        for name, flag in changed.items()
        if context.get_parameter_source(name) != click.core.ParameterSource.DEFAULT
    ]
    if clashes:
        raise click.UsageError(
            f"--checkpoints: got {', '.join(clashes)} with it; allowed: --policy RUN with --levels, --difficulty, "
            "-k, --config, --checkpoint-every, --trust-model (reserved seeds; the curve goes to RUN/curve.csv)"
        )
    with _refusals():
        result = score_checkpoints(
            policy,
            levels=parse_levels(levels) if levels else None,
            difficulties=parse_range(difficulty, "--difficulty", 0, 10) if difficulty else None,
            seeds_per_cell=seeds_per_cell,
            config_path=config_path,
            every=every or 0,
            trust_model=trust_model,
            progress_every=progress_every,
            display=progress_output,
            echo=click.echo,
        )
    click.echo("| step | training minutes | episodes | passed | pass % |\n|---:|---:|---:|---:|---:|")
    for row in result.rows:
        minutes = float(row["seconds"] or "nan") / 60.0
        click.echo(
            f"| {row['step']} | {minutes:.1f} | {row['episodes']} | {row['passed']} | {float(row['pass_pct']):.1f} |"
        )
    click.echo(f"learning curve {result.output} ({len(result.rows)} points); draw it with: aaai plot {result.output}")


def _study_battery(study_file: str, seed_key_file, seeds_per_cell, backend) -> list[tuple]:
    """``--study``: the study's battery as episodes; the options that choose other episodes refused."""
    from aaai.study.studyfile import load_study

    source = click.get_current_context().get_parameter_source
    given = {"seeds_mode": "--seeds", "levels": "--levels", "difficulty": "--difficulty", "arenas": "--arenas"}
    clashes = [flag for name, flag in given.items() if source(name) is not click.core.ParameterSource.DEFAULT]
    clashes += [
        flag for flag, value in (("--seeds-per-cell", seeds_per_cell), ("--seed-key-file", seed_key_file)) if value
    ]
    clashes += ["--backend ray"] * (backend != "local")
    if clashes:
        raise click.UsageError(
            f"--study: got {study_file!r} with {', '.join(clashes)}; allowed: --study alone (the study file "
            "names its trials: level, difficulty and seed, or arena file and seed)"
        )
    try:
        study = load_study(study_file)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    return [
        (0, 0, trial.seed, trial.arena) if trial.arena is not None else (trial.level, trial.difficulty, trial.seed)
        for trial in study.battery
    ]
