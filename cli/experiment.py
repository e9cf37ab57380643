"""``aaai experiment``: the experiments the docs report (curricula compared, time to competence)."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ConfigError, load_config
from aaai.errors import needs_extra

from .options import WORKERS, Finite, Output, Seconds, parse_levels, parse_range, rule


@click.group("experiment")
def experiment_group():
    """Experiments whose results the docs report."""


def default_action_mode() -> str:
    """gait where this version has it (more levels learned on one budget), else rotation."""
    from aaai.config import RULES

    return "gait" if "gait" in RULES["agent.action_mode"].choices else "rotation"


@experiment_group.command("curricula")
@click.option(
    "--samplers",
    default="paper,uniform,learnability,plr",
    show_default=True,
    help="Samplers to compare (curriculum.sampler), comma-separated.",
)
@click.option("--seeds", "seeds_text", default="0-2", show_default=True, help="Training seeds, e.g. '0-2'.")
@click.option(
    "--steps",
    "total_steps",
    type=rule("train.total_steps"),
    default=500_000,
    show_default=True,
    help="The budget: training steps (agent decisions) of every run.",
)
@click.option(
    "--levels", default="0,1,3,4", show_default=True, help="Active levels of every run, by id, label or name."
)
@click.option("--difficulty", default="0-3", show_default=True, help="Active difficulties of every run.")
@click.option(
    "-k",
    "--seeds-per-cell",
    "count",
    type=rule("eval.seeds_per_cell"),
    default=10,
    show_default=True,
    help="Episodes per cell on reserved seeds, and on seeds each run trained on.",
)
@click.option(
    "--curve-seeds-per-cell",
    "curve_count",
    type=click.IntRange(0, 1000),
    default=0,
    show_default=True,
    help="Reserved seeds per cell each checkpoint of a run is scored on, for its learning curve on reserved "
    "seeds (curve.csv; 0: none). At most K; the final point is the run's reserved scoreboard.",
)
@click.option(
    "--checkpoint-every",
    type=rule("train.checkpoint_every"),
    help="Steps between a run's checkpoints (train.checkpoint_every; default: the --config file's).",
)
@click.option(
    "--prune-checkpoints",
    is_flag=True,
    help="Delete a finished run's checkpoints once each is scored (final/ stays).",
)
@click.option("--envs", "num_envs", type=rule("train.num_envs"), default=2, show_default=True, help="Workers per run.")
@click.option(
    "--action-mode",
    type=click.Choice(["rotation", "velocity", "gait"]),
    help="Action mode of every run (default: gait where available, else rotation).",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(),
    help="A YAML overriding configs/default.yaml. Default: configs/curricula.yaml, the settings the committed "
    "experiment was run with (PPO's, pinned so that a change of the defaults leaves it continuable).",
)
@click.option("--out", "folder", type=Output(file_okay=False), default="experiments/curricula", show_default=True)
@click.option(
    "--jobs",
    type=WORKERS,
    default=2,
    show_default=True,
    help="Runs trained at once, each in its own process (one per core: a run of 2 workers steps them in "
    "its own process when the cores are few, train.vector auto).",
)
@click.option(
    "--progress-every",
    type=Seconds(0.1),
    default=60.0,
    show_default=True,
    help="Seconds between each run's progress lines.",
)
def curricula_command(
    samplers,
    seeds_text,
    total_steps,
    levels,
    difficulty,
    count,
    curve_count,
    checkpoint_every,
    prune_checkpoints,
    num_envs,
    action_mode,
    config_path,
    folder,
    jobs,
    progress_every,
):
    """Train every sampler on one budget, config and cells, several seeds each; score each run on
    reserved and on trained seeds; write a table and a learning-curve plot (make curricula).
    Re-running continues where it stopped."""
    from aaai.config import config_dir
    from aaai.scoring.runs import check_writable
    from aaai.train.experiments import plan, run_experiment

    seeds = parse_range(seeds_text, "--seeds", 0, 2**32 - 1)
    try:
        check_writable(Path(folder), "--out", folder=True)
        config = load_config(
            config_path or config_dir() / "curricula.yaml",
            levels=parse_levels(levels),
            difficulties=parse_range(difficulty, "--difficulty", 0, 10),
            total_steps=total_steps,
            num_envs=num_envs,
            action_mode=action_mode or default_action_mode(),
            **({"checkpoint_every": checkpoint_every} if checkpoint_every else {}),
        )
        chosen = [s.strip() for s in samplers.split(",") if s.strip()]
        experiment = plan(folder, chosen, seeds, config, count, curve_count)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    click.echo(
        f"experiment {experiment.folder}: samplers {experiment.samplers}, seeds {experiment.seeds}, "
        f"{total_steps} steps each, action mode {config.agent.action_mode}"
    )
    try:
        run_experiment(experiment, echo=click.echo, progress_every=progress_every, jobs=jobs, prune=prune_checkpoints)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment")) from None
    click.echo((experiment.folder / "table.md").read_text(), nl=False)
    click.echo(f"table {experiment.folder / 'table.md'}, plot {experiment.folder / 'curves.png'}")


@experiment_group.command("report")
@click.argument("folder", type=click.Path(exists=True, file_okay=False))
def report_command(folder):
    """Write the tables and plots of an `aaai experiment curricula` FOLDER from the runs scored so far,
    training and scoring nothing (safe while the experiment runs)."""
    from aaai.train.experiments import finished_rows, recorded, write_results

    try:
        experiment = recorded(folder)
        write_results(experiment, finished_rows(experiment))
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment report")) from None
    click.echo((experiment.folder / "table.md").read_text(), nl=False)


@experiment_group.command("power")
@click.option(
    "--from",
    "source",
    type=click.Path(exists=True, file_okay=False),
    default="experiments/curricula",
    show_default=True,
    help="A folder of `aaai experiment curricula` whose runs give the variances.",
)
@click.option(
    "--difference",
    type=Finite(0, 100, min_open=True),
    default=10.0,
    show_default=True,
    help="Points of reserved pass rate.",
)
@click.option("--alpha", type=Finite(0, 1, min_open=True, max_open=True), default=0.05, show_default=True)
@click.option("--power", type=Finite(0, 1, min_open=True, max_open=True), default=0.8, show_default=True)
@click.option("--out", "output", type=Output(dir_okay=False), help="Also write the markdown to this file.")
def power_command(source, difference, alpha, power, output):
    """How many seeds per sampler and reserved episodes per cell a difference of pass rates needs:
    a power analysis (two-sided t test) on the variance of the runs in --from."""
    from aaai.files import write_atomic
    from aaai.train.power import report

    try:
        text = report(source, difference, alpha, power)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment power")) from None
    if output:
        write_atomic(Path(output), text)
    click.echo(text, nl=False)


@experiment_group.command("competence")
@click.option("--out", "folder", type=Output(file_okay=False), default="experiments/competence", show_default=True)
@click.option(
    "--gait-steps",
    type=rule("train.total_steps"),
    default=60_000,
    show_default=True,
    help="Budget of the gait-mode run, in agent decisions (0.1 s each).",
)
@click.option(
    "--rotation-steps",
    type=rule("train.total_steps"),
    default=200_000,
    show_default=True,
    help="Budget of the rotation-mode run, in agent decisions (control steps of 0.02 s).",
)
def competence_command(folder, gait_steps, rotation_steps):
    """Time to competence: PPO on the default config (L0 d0-2) in gait and in rotation mode, every
    checkpoint scored on the 30 reserved episodes; the first to pass 90 % (make competence)."""
    from aaai.train.competence import CompetenceSettings, run_experiment

    settings = CompetenceSettings(
        budgets={"gait": gait_steps, "rotation": rotation_steps},
        checkpoint_every={"gait": max(gait_steps // 12, 1), "rotation": max(rotation_steps // 10, 1)},
    )
    try:
        table = run_experiment(folder, settings, echo=click.echo)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment")) from None
    click.echo(table.read_text(), nl=False)


@experiment_group.command("limbs")
@click.option("--levels", default="all", show_default=True, help="Levels, by id, label or name ('all': L0-L11, L2b).")
@click.option("--difficulty", default="0-10", show_default=True, help="Difficulties of every level.")
@click.option(
    "-k",
    "--seeds-per-cell",
    "count",
    type=rule("eval.seeds_per_cell"),
    default=10,
    show_default=True,
    help="Reserved seeds per (level, difficulty) cell.",
)
@click.option(
    "--arenas",
    type=click.Path(exists=True),
    multiple=True,
    help="An arena file or folder (an imported Animal-AI battery): every file scored too, summarised per category. "
    "Given more than once, all of them (e.g. BATTERY and BATTERY/unfair, where the importer puts the files not fair "
    "for the quadruped; some are valid for the sphere).",
)
@click.option(
    "--arena-seeds", type=click.IntRange(1, 1000), default=3, show_default=True, help="Seeds 0..N-1 of every arena."
)
@click.option(
    "--ppo-steps",
    type=click.IntRange(0, 10**10),
    default=0,
    show_default=True,
    help="PPO's budget per body, in agent decisions (0.1 s each); 0: the reference only.",
)
@click.option(
    "--bodies",
    default="quadruped,sphere",
    show_default=True,
    help="The bodies scored this time, comma-separated (one in each of two processes runs them side by side).",
)
@click.option(
    "--policies",
    default="reference,ppo",
    show_default=True,
    help="The policies scored this time, comma-separated: reference, ppo (ppo only with --ppo-steps).",
)
@click.option(
    "--tables-only",
    is_flag=True,
    help="Write limbs.csv and table.md from what the folder holds, scoring nothing (safe while it runs).",
)
@click.option("--out", "folder", type=Output(file_okay=False), default="experiments/limbs", show_default=True)
def limbs_command(levels, difficulty, count, arenas, arena_seeds, ppo_steps, bodies, policies, tables_only, folder):
    """The cost of limbs: the reference controller (and PPO at one budget) on the quadruped and on
    Animal-AI's sphere (agent.body: sphere), per level and per Animal-AI category; an arena file is
    checked for each body's footprint and scored for the bodies it is valid for. Writes limbs.csv and
    table.md from every scoreboard in --out. Re-running continues where it stopped; --bodies and
    --policies run it in parts."""
    from aaai.train.limbs import BODIES, POLICIES, LimbsSettings, run_experiment

    settings = LimbsSettings(
        levels=parse_levels(levels),
        difficulties=parse_range(difficulty, "--difficulty", 0, 10),
        seeds_per_cell=count,
        arenas=tuple(Path(path) for path in arenas),
        arena_seeds=arena_seeds,
        ppo_steps=ppo_steps,
        bodies=_choices(bodies, BODIES, "--bodies"),
        policies=_choices(policies, POLICIES, "--policies"),
        tables_only=tables_only,
    )
    try:
        table = run_experiment(folder, settings, echo=click.echo)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment")) from None
    click.echo(table.read_text(), nl=False)


def _choices(text: str, allowed: tuple[str, ...], option: str) -> tuple[str, ...]:
    """A comma-separated list of some of ``allowed``, in their order; anything else is one clear refusal."""
    chosen = [part.strip() for part in text.split(",") if part.strip()]
    wrong = [part for part in chosen if part not in allowed]
    if wrong or not chosen:
        raise click.BadParameter(f"got {text!r}; allowed: one or more of {', '.join(allowed)}", param_hint=option)
    return tuple(name for name in allowed if name in chosen)
