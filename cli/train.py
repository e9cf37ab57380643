"""``aaai train``: the flags parsed into a config; the trainer and its rules are aaai.train.launch's."""

from __future__ import annotations

import click

from aaai.config import ACTION_MODES, TEACHERS, ConfigError, load_config
from aaai.errors import needs_extra
from aaai.files import InUse

from .options import PROGRESS_HELP, Seconds, parse_levels, parse_range, rule
from .progress import progress_output


def _overrides(**values) -> dict:
    return {key: value for key, value in values.items() if value is not None}


@click.command("train")
@click.option("--curriculum", "mode", flag_value="curriculum", help="Sample cells by the curriculum (default).")
@click.option("--random", "mode", flag_value="random", help="Sample cells uniformly.")
@click.option("--config", "config_path", type=click.Path(), help="A YAML overriding configs/default.yaml.")
@click.option("--levels", help="Active levels by id, label or name, e.g. '0-3,5' or 'L2b,L3'.")
@click.option("--difficulty", help="Active difficulties, e.g. '0-4'.")
@click.option(
    "--steps",
    "total_steps",
    type=rule("train.total_steps"),
    help="Agent decisions in all: env.step calls, one control step (0.02 s) each in the joint modes, "
    "agent.decision_interval (0.1 s, 5 control steps) each in gait mode. The workers step together, so a run "
    "ends at the first multiple of their number at or past it.",
)
@click.option(
    "--rounds",
    type=rule("train.dagger_iterations"),
    help="A student's rounds of DAgger (train.dagger_iterations). With --resume: moves a finished or "
    "stopped student's end, so it goes on with the rounds after the ones it has.",
)
@click.option(
    "--minutes",
    "max_minutes",
    type=rule("train.max_minutes"),
    help="A budget of wall-clock minutes of training (train.max_minutes; 0: none): the run ends at the "
    "first decision past it, or at --steps, whichever comes first, and saves its final model.",
)
@click.option(
    "--envs",
    "num_envs",
    type=rule("train.num_envs"),
    help="Workers: environments stepping together (train.num_envs), in this process or one process each "
    "(train.vector).",
)
@click.option("--seed", type=rule("train.seed"), help="Seeds the sampler and the learner.")
@click.option("--agent", type=click.Choice(["ppo", "random"]), help="ppo (needs the train extra) or random.")
@click.option("--camera/--no-camera", default=None)
@click.option("--camera-resolution", type=rule("sensors.camera_resolution"), help="Camera pixels a side.")
@click.option("--rays/--no-rays", default=None)
@click.option("--run", "run_dir", type=click.Path(), help="Run folder (default runs/run-<date>-<time>).")
@click.option("--resume", "resume_dir", type=click.Path(), help="Continue the run in this folder.")
@click.option(
    "--backend",
    type=click.Choice(["sb3", "rllib"]),
    help="sb3 (default): stable-baselines3 PPO on local workers; rllib: RLlib PPO on Ray (the ray "
    "extra), its env runners anywhere on a cluster. --resume uses the run's own.",
)
@click.option("--address", help="With --backend rllib: join the Ray cluster whose head is at this address.")
@click.option(
    "--sampler",
    type=click.Choice(["paper", "uniform", "learnability", "plr"]),
    help="How the curriculum weights cells (curriculum.sampler; docs, Training and curricula). --random is uniform.",
)
@click.option("--progress-every", type=Seconds(0.1), default=30.0, show_default=True, help=PROGRESS_HELP)
@click.option(
    "--action-mode",
    type=click.Choice(ACTION_MODES),
    help="rotation or velocity: 8 joint targets a control step; gait: forward, turn, crouch of the gait, "
    "held for agent.decision_interval (default: the config's).",
)
@click.option(
    "--teacher",
    type=click.Choice(TEACHERS),
    help="Train a student of this teacher by DAgger instead of PPO: it sees only the agent's senses and "
    "learns the teacher's actions (train.dagger_* keys; docs, Learned agents).",
)
@click.option(
    "--init-from",
    type=click.Path(exists=True),
    help="A run folder or model .zip whose policy weights PPO starts from (e.g. a student, to fine-tune).",
)
@click.option(
    "--data-from",
    "dagger_data_from",
    type=click.Path(exists=True, file_okay=False),
    help="With a teacher: start from this DAgger run's saved rounds (train.dagger_data_from): the student "
    "is fitted on them, then DAgger goes on with the rounds after them (docs, Learned agents).",
)
@click.option(
    "--trust-model",
    is_flag=True,
    help="With --resume: load the run's checkpoint with its library's own loader, which unpickles it "
    "(stable-baselines3 models that cannot be rebuilt without it; RLlib checkpoints not signed on "
    "this machine). Only for runs you trust.",
)
def train_command(
    mode,
    config_path,
    levels,
    difficulty,
    total_steps,
    rounds,
    max_minutes,
    num_envs,
    seed,
    agent,
    camera,
    camera_resolution,
    rays,
    run_dir,
    resume_dir,
    backend,
    address,
    action_mode,
    teacher,
    init_from,
    dagger_data_from,
    trust_model,
    sampler,
    progress_every,
):
    """Train on a curriculum of (level, difficulty) cells; checkpoints and logs go to the run folder."""
    from aaai.train.launch import check_options, new_run_dir, step_unit, train_run
    from aaai.train.training import write_failure
    from aaai.train.workers import WorkerLost

    given = {
        mode or "curriculum": mode,
        "config": config_path,
        **dict(
            levels=levels,
            difficulty=difficulty,
            envs=num_envs,
            minutes=max_minutes,
            seed=seed,
            agent=agent,
            camera=camera,
            camera_resolution=camera_resolution,
            rays=rays,
            run=run_dir,
            backend=backend,
            action_mode=action_mode,
            teacher=teacher,
            init_from=init_from,
            data_from=dagger_data_from,
            sampler=sampler,
        ),
    }
    try:  # flags that cannot go together: refused before any work
        check_options(resume_dir, backend, address, [name for name, value in given.items() if value is not None])
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    try:
        if resume_dir:  # --steps may move the run's end; other options come from the run's config
            run_dir, config = resume_dir, None
        else:
            config = load_config(
                config_path,
                **_overrides(
                    mode=mode,
                    levels=parse_levels(levels) if levels is not None else None,
                    difficulties=parse_range(difficulty, "--difficulty", 0, 10) if difficulty is not None else None,
                    total_steps=total_steps,
                    dagger_iterations=rounds,
                    max_minutes=max_minutes,
                    num_envs=num_envs,
                    seed=seed,
                    agent=agent,
                    camera=camera,
                    camera_resolution=camera_resolution,
                    rays=rays,
                    action_mode=action_mode,
                    teacher=teacher,
                    init_from=init_from,
                    dagger_data_from=dagger_data_from,
                    sampler=sampler,
                ),
            )
            run_dir = run_dir or new_run_dir()
        trained = train_run(
            run_dir,
            config,
            resume=bool(resume_dir),
            backend=backend,
            total_steps=total_steps,
            rounds=rounds,
            address=address,
            trust_model=trust_model,
            progress_every=progress_every,
            display=progress_output,
            say=lambda message: click.echo(message, err=True),
        )
    except InUse as error:  # another process trains this run: its pid named
        raise click.ClickException(str(error)) from None
    except (ConfigError, FileExistsError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except OSError as error:  # a full disk, a permission taken away: the file named, the run resumable
        raise click.ClickException(write_failure(error, run_dir)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai train")) from None
    except WorkerLost as error:  # a worker process killed: it named, the run resumable from its last checkpoint
        raise click.ClickException(
            f"{error}; the run keeps its last checkpoint: aaai train --resume {run_dir}"
        ) from None
    result = trained.result
    if trained.student:
        click.echo(
            f"run {result.run.path}: {result.steps} labelled agent decisions, {result.episodes} episodes"
            + (f" (resumed after {result.resumed_from} iterations)" if resume_dir else "")
            + f"; score it with: aaai eval --policy {result.run.path}"
        )
        return
    run_config = load_config(result.run.read_config())
    curriculum = run_config.curriculum
    click.echo(
        f"run {result.run.path}: {result.steps} {step_unit(run_config)}, {result.episodes} episodes"
        + (f" (resumed at step {result.resumed_from})" if resume_dir else "")
    )
    click.echo(
        f"cells: levels {list(curriculum.levels)} x difficulties {list(curriculum.difficulties)}; "
        f"heatmap {result.run.path / 'curriculum.png'}"
    )
