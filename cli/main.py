"""The ``aaai`` command group and most of its commands (``show`` and ``validate`` have their own files)."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

import click
import numpy as np

from aaai.config import Config, ConfigError, describe_ids, load_config, parse_int_set, read_yaml
from aaai.env import AnimalAIEnv
from aaai.errors import needs_extra
from aaai.files import InUse
from aaai.levels import SEED_LIMIT, all_levels, describe_levels, generate, get_level, level_ids
from aaai.registration import level_env_id
from aaai.scoring.episodes import play
from aaai.scoring.policies import resolve
from aaai.scoring.runs import RunFolder
from aaai_cli.options import COUNT, DIFFICULTY, MANY, SEED, WORKERS, Finite, Output, SeedList, rule

POLICY_HELP = (
    "random, reference (the privileged reference controller), gait (the example trot), "
    "a model .zip, a run folder or module:callable"
)
TRUST_HELP = (
    "Load a model file with stable-baselines3's own loader, which unpickles it and so runs any code in "
    "it (default: rebuilt without unpickling; docs, Scoring agents you did not write). Only for files "
    "you trust."
)


def parse_range(text: str, name: str, low: int, high: int) -> list[int]:
    """'0-3,5' -> [0, 1, 2, 3, 5], each checked to lie in low..high."""
    try:
        return parse_int_set(text, name, low, high)
    except ConfigError as error:
        raise click.BadParameter(str(error).split(": ", 1)[1], param_hint=name) from None


def parse_levels(text: str | None, name: str = "--levels") -> list[int]:
    """'0-3,5', 'L2b,L3' or 'food_contact' -> those level ids, each a registered level (by id, label
    or name; ranges by id); None or 'all' -> every registered level."""
    known = level_ids()
    if text is None or text.strip() == "all":
        return known
    allowed = (
        f"all, or a list of levels by id ({describe_ids(known)}), label or name ({describe_levels()}), "
        "with id ranges like '0-3,5'"
    )
    ids, numeric = [], []
    for part in (part.strip() for part in text.split(",")):
        try:
            ids.append(get_level(part).id)  # an id, label or name (a custom level's may start with a digit)
        except ConfigError:
            if not part[:1].isdigit():  # not an id range either
                refusal = f"got {text!r}: no level {part!r}; allowed: {allowed}"
                raise click.BadParameter(refusal, param_hint=name) from None
            numeric.append(part)
    if numeric:
        try:
            ids += parse_int_set(",".join(numeric), name, 0, max(known))
        except ConfigError:
            raise click.BadParameter(f"got {text!r}; allowed: {allowed}", param_hint=name) from None
    missing = [level for level in ids if level not in known]
    if missing:
        raise click.BadParameter(
            f"got {text!r}, and level {missing[0]} does not exist; allowed: {allowed}", param_hint=name
        )
    return sorted(set(ids))


@click.group()
@click.version_option(package_name="aaai")
def cli():
    """Articulated Animal AI: a quadruped finding food in seeded cognition test levels."""


@cli.command("levels")
def levels_command():
    """List the levels and their Gymnasium ids."""
    for level in all_levels().values():
        click.echo(f"{level.label:<4} {level.name:<18} {level.title:<28} {level_env_id(level)}")


@cli.command("spec")
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


@cli.command("run")
@click.option(
    "--levels",
    "levels_text",
    default="0",
    show_default=True,
    help="Levels by id, label or name, e.g. '0-1' or 'L2b,L3'.",
)
@click.option("--difficulty", "difficulty_text", default="0", show_default=True, help="Difficulties, e.g. '0-4'.")
@click.option("--episodes", type=COUNT, default=1, show_default=True, help="Episodes per cell.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="First episode seed.")
@click.option("--policy", default="random", show_default=True, help=POLICY_HELP)
@click.option("--config", "config_path", type=click.Path(), help="A YAML overriding configs/default.yaml.")
@click.option(
    "--max-steps",
    type=rule("episode.max_steps"),
    help="Episode length T (overrides the config and the level's time limit).",
)
@click.option("--camera/--no-camera", default=None, help="Turn the head camera on or off.")
@click.option("--rays/--no-rays", default=None, help="Turn the rays on or off.")
@click.option(
    "--arena",
    "arena",
    type=click.Path(),
    help="Run this arena file (docs, Write your own test) instead "
    "of generated levels: --episodes episodes, seeds from --seed.",
)
@click.option(
    "--action-mode",
    type=click.Choice(["rotation", "velocity", "gait"]),
    help="rotation or velocity: 8 joint targets a control step; gait: forward, turn, crouch of the gait, "
    "held for agent.decision_interval (default: the config's).",
)
@click.option("--trust-model", is_flag=True, help=TRUST_HELP)
@click.option(
    "--replay",
    type=click.Path(dir_okay=False),
    help="Run a replay file (aaai play --replays, aaai eval --save-replays) with its own level, config "
    "and actions, and check that it ends as recorded, bit for bit (--arena: where its arena file is now).",
)
def run_command(
    levels_text,
    difficulty_text,
    episodes,
    seed,
    policy,
    config_path,
    max_steps,
    camera,
    rays,
    arena,
    action_mode,
    trust_model,
    replay,
):
    """Run episodes with a policy (random actions by default) and print a summary of each."""
    if replay is not None:
        from aaai_cli.play import run_replay_file

        return run_replay_file(replay, arena)
    levels = parse_levels(levels_text)
    difficulties = parse_range(difficulty_text, "--difficulty", 0, 10)
    last = seed + episodes * (1 if arena is not None else len(levels) * len(difficulties)) - 1
    if last >= SEED_LIMIT:  # episode i plays seed --seed + i: each must be one a level takes
        raise click.BadParameter(
            f"got {seed} for {last - seed + 1} episodes, whose last seed would be {last}; allowed: seeds up "
            f"to {SEED_LIMIT - 1} (a first seed of at most {SEED_LIMIT - (last - seed + 1)})",
            param_hint="--seed",
        )
    overrides = {
        k: v
        for k, v in dict(max_steps=max_steps, camera=camera, rays=rays, action_mode=action_mode).items()
        if v is not None
    }
    try:
        for level in levels:
            get_level(level)
        chosen = resolve(policy, trust_model)
        env = AnimalAIEnv(level=levels[0], config=chosen.play_config(config_path), arena=arena, **overrides)
        actor = chosen.build(env)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    click.echo(
        f"{'level':<20} {'diff':>4} {'seed':>6} {'return':>8} {'max':>6} {'steps':>6} "
        f"{'food':>4} {'walls':>5} {'end':<10} {'steps/s':>8}"
    )
    if arena is not None:
        from aaai.task.arena import load_arena

        try:  # every episode's instance is checked before any runs
            for episode in range(episodes):
                load_arena(arena, seed + episode)
        except ConfigError as error:
            env.close()
            raise click.UsageError(str(error)) from None
        for episode in range(episodes):
            click.echo(run_episode(env, None, None, seed + episode, actor))
        env.close()
        return
    episode = 0
    for level in levels:
        for difficulty in difficulties:
            for _ in range(episodes):
                summary = run_episode(env, level, difficulty, seed + episode, actor)
                episode += 1
                click.echo(summary)
    env.close()


def run_episode(env: AnimalAIEnv, level: int, difficulty: int, seed: int, policy) -> str:
    """Plays one episode to its end; its line of the `aaai run` table. With level None, the env's
    arena file."""
    result = play(env, policy, seed, options=None if level is None else {"level": level, "difficulty": difficulty})
    info = result.info
    rate = info["steps"] / max(result.step_seconds, 1e-9)
    if level is None:
        name, difficulty = Path(env.arena).name, info["difficulty"]
    else:
        name = f"{get_level(level).label} {info['level_name']}"
    return (
        f"{name:<20} {difficulty:>4} {seed:>6} {result.episode_return:>8.3f} {info['max_reward']:>6.2f} "
        f"{info['steps']:>6} {info['food_eaten']:>4} {info['wall_hits']:>5} {result.end:<10} {rate:>8.0f}"
    )


def with_action_mode(config: Config, action_mode: str | None) -> Config:
    """``config`` scored in ``action_mode`` (unchanged for None). A model trained in another mode
    is refused when it is loaded."""
    if action_mode is not None:
        config = config.replace(action_mode=action_mode)
    return config


def step_note(config: Config) -> str:
    """The unit of a progress line's steps: 'steps: gait decisions of 0.1 s' or 'steps: control steps of 0.02 s'."""
    agent, physics = config.agent, config.physics
    if agent.action_mode == "gait":
        return f"steps: gait decisions of {agent.decision_interval:g} s"
    return f"steps: control steps of {physics.timestep * physics.action_repeat:g} s"


def step_unit(config: Config) -> str:
    """What a training step counts in a run of this config: agent decisions or control steps."""
    agent = config.agent
    if agent.action_mode == "gait":
        return f"agent decisions (of {agent.decision_interval:g} s each)"
    physics = config.physics
    return f"agent decisions (control steps of {physics.timestep * physics.action_repeat:g} s)"


class Seconds(click.FloatRange):
    """A number of seconds, at least ``min``: not NaN or infinity (which FloatRange lets through)."""

    name = "seconds"

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"got {value!r}; allowed: a finite number of seconds, {self.min} or more", param, ctx)
        return number


PROGRESS_HELP = (
    "Seconds between progress lines when the output is not a terminal (piped, nohup); in a terminal a progress bar."
)


REDRAW = 0.25  # seconds between redraws of a terminal's progress bar


@contextlib.contextmanager
def progress_output(report):
    """Yields the function to advance ``report`` (an aaai.train.training.Progress) with: a progress bar
    showing its rate, episodes, pass rate and ETA in a terminal; elsewhere (piped, nohup) its line
    every ``report.every`` seconds, and once more at the end."""
    from aaai.train.training import print_lines

    if sys.stdout.isatty():
        with click.progressbar(
            length=report.total, label=report.label, show_pos=True, show_eta=False, item_show_func=lambda item: item
        ) as bar:
            bar.update(report.done)
            pending, drawn = [0], [0.0]

            def update(n: int) -> None:  # the bar is redrawn at most every REDRAW seconds: a redraw
                report.update(n)  # costs about 1000 times a step's bookkeeping
                pending[0] += n
                now = time.monotonic()
                if now - drawn[0] >= REDRAW:
                    bar.update(pending[0], current_item=report.details())
                    pending[0], drawn[0] = 0, now

            yield update
            bar.update(pending[0], current_item=report.details())
    else:
        report.write = print_lines(sys.stdout)
        yield report.update
        report.write(report.line())


def steps_done(resume_dir: str | None) -> int:
    """The steps a run to be resumed has done (at its newest saved point); 0 for a new run."""
    if not resume_dir:
        return 0
    saved = RunFolder(resume_dir).saved() if Path(resume_dir).is_dir() else []
    return max(int(RunFolder._step_of(saved[0], unreadable=0)), 0) if saved else 0


def _overrides(**values) -> dict:
    return {key: value for key, value in values.items() if value is not None}


@cli.command("train")
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
    type=click.Choice(["rotation", "velocity", "gait"]),
    help="rotation or velocity: 8 joint targets a control step; gait: forward, turn, crouch of the gait, "
    "held for agent.decision_interval (default: the config's).",
)
@click.option(
    "--teacher",
    type=click.Choice(["reference"]),
    help="Train a student of this teacher by DAgger instead of PPO: it sees only the agent's senses and "
    "learns the teacher's actions (train.dagger_* keys; docs, Learned agents).",
)
@click.option(
    "--init-from",
    type=click.Path(exists=True),
    help="A run folder or model .zip whose policy weights PPO starts from (e.g. a student, to fine-tune).",
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
    trust_model,
    sampler,
    progress_every,
):
    """Train on a curriculum of (level, difficulty) cells; checkpoints and logs go to the run folder."""
    from aaai.scoring.runs import run_backend
    from aaai.train.rllib_learner import train_rllib
    from aaai.train.training import Progress, train, write_failure

    ignored = {
        name: value
        for name, value in {
            mode or "curriculum": mode,
            "config": config_path,
            **dict(
                levels=levels,
                difficulty=difficulty,
                envs=num_envs,
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
                sampler=sampler,
            ),
        }.items()
        if value is not None
    }
    if address and (backend or (resume_dir and run_backend(resume_dir))) != "rllib":
        raise click.UsageError("--address: only --backend rllib runs on a cluster")
    if resume_dir and ignored:  # a resumed run keeps its own config: say so rather than ignore the option
        options = ", ".join(f"--{name.replace('_', '-')}" for name in ignored)
        raise click.UsageError(
            f"--resume continues a run with the config it was started with; {options} cannot "
            "change on resume (allowed with --resume: --steps, to move the run's end)"
        )
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
                    num_envs=num_envs,
                    seed=seed,
                    agent=agent,
                    camera=camera,
                    camera_resolution=camera_resolution,
                    rays=rays,
                    action_mode=action_mode,
                    teacher=teacher,
                    init_from=init_from,
                    sampler=sampler,
                ),
            )
            run_dir = run_dir or time.strftime("runs/run-%Y%m%d-%H%M%S")
        total = total_steps or (config or load_config(RunFolder(run_dir).read_config())).train.total_steps
        use_rllib = (run_backend(resume_dir) if resume_dir else backend) == "rllib"
        say = lambda message: click.echo(message, err=True)  # noqa: E731
        if (config or load_config(RunFolder(run_dir).read_config())).train.teacher != "none":
            if use_rllib:
                raise click.UsageError("--teacher: a student is trained with stable-baselines3 (--backend sb3)")
            if total_steps is not None:
                raise click.UsageError(
                    f"--steps: got {total_steps} for a student of a teacher, whose budget is rounds of DAgger, "
                    "not steps; allowed: no --steps (set train.dagger_iterations and train.dagger_episodes)"
                )
            from aaai.train.student import train_student

            result = train_student(run_dir, config, resume=bool(resume_dir), say=say)
            click.echo(
                f"run {result.run.path}: {result.steps} labelled agent decisions, {result.episodes} episodes"
                + (f" (resumed after {result.resumed_from} iterations)" if resume_dir else "")
                + f"; score it with: aaai eval --policy {result.run.path}"
            )
            return
        unit_config = load_config(config or RunFolder(run_dir).read_config())
        report = Progress(
            total, done=steps_done(resume_dir), every=progress_every, label=f"training ({step_note(unit_config)})"
        )
        with progress_output(report) as update:
            if use_rllib:
                result = train_rllib(
                    run_dir,
                    config,
                    resume=bool(resume_dir),
                    progress=update,
                    address=address,
                    total_steps=total_steps if resume_dir else None,
                    say=say,
                    trust=trust_model,
                )
            else:
                result = train(
                    run_dir,
                    config,
                    resume=bool(resume_dir),
                    progress=update,
                    total_steps=total_steps if resume_dir else None,
                    say=say,
                    on_episodes=report.on_episodes,
                    trust=trust_model,
                )
    except InUse as error:  # another process trains this run: its pid named
        raise click.ClickException(str(error)) from None
    except (ConfigError, FileExistsError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except OSError as error:  # a full disk, a permission taken away: the file named, the run resumable
        raise click.ClickException(write_failure(error, run_dir)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai train")) from None
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


@cli.command("eval")
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
    help="A run folder, a model .zip, random, reference, gait, or module:callable (called with the env).",
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
    "0..K-1 (-k, default eval.seeds_per_cell) or --seeds 1,2,3; a summary per arena and per category.",
)
@click.option(
    "--action-mode",
    type=click.Choice(["rotation", "velocity", "gait"]),
    help="Score in this action mode (default: the run's or config's). A model is scored only in the "
    "mode it was trained in.",
)
@click.option("--trust-model", is_flag=True, help=TRUST_HELP)
@click.option("--progress-every", type=Seconds(0.1), default=30.0, show_default=True, help=PROGRESS_HELP)
@click.option(
    "--save-replays",
    type=Output(file_okay=False),
    help="Save each scored episode's replay (JSON: level, seed, config, actions) in this folder, for "
    "aaai run --replay and aaai show --replay (--backend local only).",
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
    trust_model,
    progress_every,
    save_replays,
):
    """Score a policy on fixed seeds: a CSV row per episode and a summary per level."""
    from aaai.tools.baselines import one_thread

    one_thread()  # one episode at a time: a small network gains nothing from more torch threads
    if arenas is not None:
        return eval_arenas(
            arenas,
            seeds_mode,
            policy,
            seeds_per_cell,
            config_path,
            output,
            levels,
            difficulty,
            seed_key_file,
            backend,
            action_mode,
            trust_model,
            save_replays,
            progress_every,
        )
    if save_replays is not None and backend != "local":
        raise click.UsageError("--save-replays: only with --backend local")
    from aaai.scoring.evaluation import cells_for, evaluate, policy_record, summarise, summary_markdown, write_summary
    from aaai.task.seeds import read_seed_key

    try:
        key = read_seed_key(seed_key_file)
    except ValueError as error:
        raise click.UsageError(str(error)) from None

    try:
        policy = resolve(policy, trust_model)
        run_folder = Path(policy.run) if policy.run else None
        config = with_action_mode(policy.config(config_path), action_mode)
        level_list = parse_levels(levels) if levels else list(config.curriculum.levels)
        difficulty_list = (
            parse_range(difficulty, "--difficulty", 0, 10) if difficulty else list(config.curriculum.difficulties)
        )
        count = seeds_per_cell or config.eval.seeds_per_cell
        cells = cells_for(level_list, difficulty_list, seeds_mode, count, key)
        label = seeds_mode if seeds_mode in ("reserved", "train") else "list"
        output = Path(output) if output else (run_folder or Path(".")) / f"scoreboard_{label}.csv"
        record = policy_record(policy, seeds_mode, key)
        episodes = sum(len(cell.seeds) for cell in cells)
        from aaai.train.training import Progress

        report = Progress(episodes, label="scoring", unit="episodes", every=progress_every)
        with progress_output(report) as update:

            def on_episode(row: dict) -> None:
                report.add_episodes([row["outcome"] != "failed"], steps=int(row["steps"]))
                update(1)

            if backend == "ray":
                from aaai.scoring.distributed import evaluate_on_ray

                rows = evaluate_on_ray(
                    policy,
                    cells,
                    output,
                    config,
                    address=address,
                    workers=workers,
                    on_episode=on_episode,
                    record=record,
                )
            else:
                rows = evaluate(
                    policy, cells, output, config, record=record, **replay_hooks(save_replays, policy, on_episode)
                )
    except InUse as error:  # another eval writes this scoreboard: its pid named
        raise click.ClickException(str(error)) from None
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except OSError as error:  # an output that became unwritable midway (its rows so far stay)
        raise click.ClickException(f"{str(error.filename or output)!r}: {error.strerror or error}") from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai eval")) from None
    summary = summarise(rows)
    summary_path = _write_summary(write_summary, summary, output)
    click.echo(summary_markdown(summary), nl=False)
    click.echo(f"scoreboard {output} ({len(rows)} episodes); summary {summary_path}")


def eval_arenas(
    arenas,
    seeds_mode,
    policy,
    seeds_per_cell,
    config_path,
    output,
    levels,
    difficulty,
    seed_key_file,
    backend,
    action_mode=None,
    trust_model=False,
    save_replays=None,
    progress_every=30.0,
):
    """``aaai eval --arenas``: every arena file of the battery on seeds 0..K-1 (or a --seeds list)."""
    from aaai.scoring.evaluation import (
        evaluate_arenas,
        policy_record,
        summarise_arenas,
        summary_markdown,
        write_summary,
    )
    from aaai.task.arena import arena_files, arena_meta

    clashes = [
        name
        for name, value in (("--levels", levels), ("--difficulty", difficulty), ("--seed-key-file", seed_key_file))
        if value is not None
    ]
    if backend != "local":
        clashes.append("--backend ray")
    if clashes:
        raise click.UsageError(
            f"--arenas: {', '.join(clashes)} cannot be used with it (an arena file is its own level)"
        )
    try:
        policy = resolve(policy, trust_model)
        run_folder = Path(policy.run) if policy.run else None
        config = with_action_mode(policy.config(config_path), action_mode)
        count = seeds_per_cell or config.eval.seeds_per_cell
        if seeds_mode == "reserved":  # the default: an arena's seeds are 0..K-1
            seeds, label = list(range(count)), f"0-{count - 1}"
        elif seeds_mode == "train":
            raise ConfigError("--seeds: got 'train' with --arenas; allowed: a list like 1,2,3 (default 0..K-1)")
        else:
            try:
                seeds, label = [int(part) for part in seeds_mode.split(",")], seeds_mode
            except ValueError:
                raise ConfigError(f"--seeds: got {seeds_mode!r}; allowed: a list like 1,2,3 (default 0..K-1)") from None
        files = arena_files(arenas)
        categories = {path.name: arena_meta(path)["category"] for path in files}
        output = Path(output) if output else (run_folder or Path(".")) / "scoreboard_arenas.csv"
        record = {**policy_record(policy, "list"), "seeds": label, "arenas": str(arenas)}
        episodes = len(files) * len(seeds)
        from aaai.train.training import Progress

        report = Progress(episodes, label="scoring", unit="episodes", every=progress_every)
        with progress_output(report) as update:

            def on_episode(row: dict) -> None:
                report.add_episodes([row["outcome"] != "failed"], steps=int(row["steps"]))
                update(1)

            rows = evaluate_arenas(
                policy,
                files,
                seeds,
                output,
                config,
                record=record,
                **replay_hooks(save_replays, policy, on_episode, files),
            )
    except InUse as error:  # another eval writes this scoreboard: its pid named
        raise click.ClickException(str(error)) from None
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except OSError as error:  # an output that became unwritable midway (its rows so far stay)
        raise click.ClickException(f"{str(error.filename or output)!r}: {error.strerror or error}") from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai eval")) from None
    summary = summarise_arenas(rows, categories)
    summary_path = _write_summary(write_summary, summary, output)
    click.echo(summary_markdown(summary), nl=False)
    click.echo(f"scoreboard {output} ({len(rows)} episodes); summary {summary_path}")


def _write_summary(write_summary, summary: list[dict], output: Path) -> Path:
    """The scoreboard's summary file; a file that cannot be written is named (the summary is printed anyway)."""
    try:
        return write_summary(summary, output)
    except OSError as error:
        click.echo(summary_markdown_of(summary), nl=False)
        where = getattr(error, "filename", None) or output.with_name(output.stem + "_summary.md")
        raise click.ClickException(
            f"cannot write the summary {str(where)!r}: {error.strerror or error}; the "
            f"scoreboard {str(output)!r} is whole, and the summary is printed above"
        ) from None


def summary_markdown_of(summary: list[dict]) -> str:
    from aaai.scoring.evaluation import summary_markdown

    return summary_markdown(summary)


@cli.command("demos")
@click.option("--policy", default="reference", show_default=True, help=POLICY_HELP)
@click.option(
    "--levels", default="all", show_default=True, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b,L3', or all."
)
@click.option("--difficulty", default="0-10", show_default=True)
@click.option("-k", "--episodes-per-cell", "count", type=rule("eval.seeds_per_cell"), default=1, show_default=True)
@click.option(
    "--seeds",
    "seeds_mode",
    type=SeedList(),
    default="train",
    show_default=True,
    help="train (fixed draws from the training range), reserved, or a list like 1,2,3.",
)
@click.option(
    "--action-mode",
    type=click.Choice(["rotation", "velocity", "gait"]),
    help="The actions recorded (default: the config's, or the run's for a run folder).",
)
@click.option("--config", "config_path", type=click.Path(), help="A YAML for the env.")
@click.option(
    "--out",
    "out",
    type=Output(file_okay=False),
    required=True,
    help="The folder holding the Minari datasets (MINARI_DATASETS_PATH to load them).",
)
@click.option("--dataset-id", help="The dataset's id (default aaai/<policy>-v0).")
def demos_command(policy, levels, difficulty, count, seeds_mode, action_mode, config_path, out, dataset_id):
    """Record a policy's episodes as a Minari dataset (the demos extra): the agent's own observations,
    the actions, rewards and ends, and each episode's seed, level and difficulty."""
    from aaai.scoring.evaluation import seeds_for

    try:
        import minari  # noqa: F401 (the demos extra: checked before anything is recorded)

        from aaai.scoring.demos import dataset_id_for, record
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai demos")) from None
    try:
        chosen = resolve(policy)
        config = with_action_mode(chosen.config(config_path), action_mode)
        plan = [
            (level, d, seed)
            for level in parse_levels(levels)
            for d in parse_range(difficulty, "--difficulty", 0, 10)
            for seed in seeds_for(seeds_mode, level, d, count)
        ]
        dataset_id = dataset_id or dataset_id_for(policy)
        with click.progressbar(length=len(plan), label=f"recording {len(plan)} episodes", show_pos=True) as bar:
            record(chosen, plan, Path(out), config, dataset_id, on_episode=lambda index: bar.update(1))
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai demos")) from None
    click.echo(
        f"dataset {dataset_id} in {out}: {len(plan)} episodes; load it with "
        f"MINARI_DATASETS_PATH={out} python -c \"import minari; minari.load_dataset('{dataset_id}')\""
    )


@cli.command("diagnose")
@click.option("--policy", required=True, help=POLICY_HELP)
@click.option(
    "--scoreboard",
    type=click.Path(exists=True, dir_okay=False),
    required=True,
    help="The policy's scoreboard CSV (aaai eval): its failed episodes are replayed.",
)
@click.option("--levels", help="Only these levels, by id, label or name, e.g. '7,8' or 'L8'.")
@click.option("--limit", type=click.IntRange(1, MANY), help="At most this many failed episodes per level.")
@click.option("--config", "config_path", type=click.Path(), help="A YAML for the env (default: the run's config).")
def diagnose_command(policy, scoreboard, levels, limit, config_path):
    """Why a policy fails: its failed episodes replayed, each sorted into a first cause (fell, never
    saw food, lost sight of it, saw it but did not reach it, ate the wrong food)."""
    from aaai.scoring.diagnose import diagnose, table_markdown

    try:
        chosen = resolve(policy)
        failures = diagnose(
            chosen,
            Path(scoreboard),
            chosen.config(config_path),
            parse_levels(levels) if levels else None,
            limit,
        )
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    click.echo(table_markdown(failures), nl=False)


@cli.command("baselines")
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
    "--only",
    help="Score only these policies (e.g. 'student,ppo_gait'); the table and heatmap still "
    "show every scoreboard already in --out.",
)
def baselines_command(demo_run, folder, levels, difficulty, count, workers, student_run, ppo_gait_run, only):
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


@cli.command("seeds")
@click.option(
    "--levels", default="all", show_default=True, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b,L3', or all."
)
@click.option("--difficulty", default="0-10", show_default=True)
@click.option("-k", "--seeds-per-cell", "count", type=rule("eval.seeds_per_cell"), default=10, show_default=True)
@click.option(
    "--seed-key-file",
    type=click.Path(dir_okay=False),
    help="A file holding a secret key: print the hidden list it stands for (or set AAAI_SEED_KEY).",
)
def seeds_command(levels, difficulty, count, seed_key_file):
    """Print the reserved evaluation seeds of each (level, difficulty) cell."""
    from aaai.task.seeds import key_record, read_seed_key, reserved_seeds

    try:
        key = read_seed_key(seed_key_file)
    except ValueError as error:
        raise click.UsageError(str(error)) from None
    click.echo(f"seed key: {key_record(key)}")
    for level in parse_levels(levels):
        for d in parse_range(difficulty, "--difficulty", 0, 10):
            seeds = reserved_seeds(level, d, count, key)
            click.echo(f"{get_level(level).label} d{d}: " + ",".join(str(s) for s in seeds))


@cli.command("bench")
@click.option("--levels", help="Levels to measure by id, label or name (default: all).")
@click.option(
    "--rounds",
    type=click.IntRange(1, 1000),
    default=5,
    show_default=True,
    help="Alternated rounds: each figure is timed once per round; ratios are medians over rounds.",
)
@click.option(
    "--steps", type=click.IntRange(100, MANY), default=1000, show_default=True, help="Steps per figure and round."
)
@click.option("--resets", type=click.IntRange(5, MANY), default=50, show_default=True, help="Resets timed per level.")
@click.option(
    "--worker-steps",
    type=click.IntRange(100, MANY),
    default=1000,
    show_default=True,
    help="Steps per worker and round in the 1/2/4-worker runs.",
)
@click.option(
    "--train-steps",
    type=rule("train.total_steps", low=0),
    default=4096,
    show_default=True,
    help="Steps per round of PPO, the random agent and the environment alone (0: no training row).",
)
@click.option("--train-envs", type=rule("train.num_envs"), help="Workers of the training row (default: the config's).")
@click.option(
    "--config",
    "config_path",
    type=click.Path(),
    help="A YAML overriding configs/default.yaml for the training row (its train and curriculum keys, senses).",
)
@click.option("--memory-steps", type=click.IntRange(1000, MANY), default=20000, show_default=True)
@click.option(
    "--out",
    "folder",
    type=Output(what="folder"),
    default="bench",
    show_default=True,
    help="Folder for bench.json and bench.md.",
)
def bench_command(
    levels, rounds, steps, resets, worker_steps, train_steps, train_envs, config_path, memory_steps, folder
):
    """Measure steps/s against a bare PyBullet loop and MuJoCo Ant-v5, training against the
    environment alone, resets, workers and memory; alternated rounds, medians and spreads."""
    from aaai.tools import bench, bench_report

    level_list = parse_levels(levels) if levels else None
    train_config: dict = {}
    if config_path is not None:
        try:
            load_config(config_path)  # checked whole first: one message naming the key and the value
            train_config = read_yaml(config_path)
        except ConfigError as error:
            raise click.BadParameter(str(error), param_hint="--config") from None
    if train_envs:
        train_config = {**train_config, "train": {**train_config.get("train", {}), "num_envs": train_envs}}
    results = bench.run(
        level_list,
        steps=steps,
        rounds=rounds,
        resets=resets,
        worker_steps=worker_steps,
        train_steps=train_steps,
        memory_steps=memory_steps,
        train_config=train_config or None,
        log=lambda text: click.echo(text, err=True),
    )
    json_path, md_path = bench_report.write(results, Path(folder))
    click.echo(bench_report.markdown(results), nl=False)
    click.echo("ratios (medians): " + ", ".join(f"{k} {v:.2f}" for k, v in results["ratios"].items()))
    click.echo(f"written: {json_path}, {md_path}")


@cli.command("plot")
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False))
@click.option(
    "--out",
    "output",
    type=Output(dir_okay=False),
    default="learning_curves.png",
    show_default=True,
    help="The PNG to write.",
)
@click.option(
    "--smooth",
    type=click.IntRange(1, MANY),
    default=50,
    show_default=True,
    help="Episodes in each point's running mean.",
)
def plot_command(runs, output, smooth):
    """Draw the learning curves of RUN folders on one figure: task return and pass rate against steps."""
    from aaai.train.experiments import plot_runs

    try:
        path = plot_runs(list(runs), output, smooth=smooth)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai plot")) from None
    click.echo(f"learning curves of {len(runs)} run(s): {path}")


@cli.group("experiment")
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
        )
        experiment = plan(folder, [s.strip() for s in samplers.split(",") if s.strip()], seeds, config, count)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    click.echo(
        f"experiment {experiment.folder}: samplers {experiment.samplers}, seeds {experiment.seeds}, "
        f"{total_steps} steps each, action mode {config.agent.action_mode}"
    )
    try:
        run_experiment(experiment, echo=click.echo, progress_every=progress_every, jobs=jobs)
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai experiment")) from None
    click.echo((experiment.folder / "table.md").read_text(), nl=False)
    click.echo(f"table {experiment.folder / 'table.md'}, plot {experiment.folder / 'curves.png'}")


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


@cli.command("import-animalai")
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


# Commands that live in their own files.
from aaai_cli.play import play as play_command  # noqa: E402
from aaai_cli.play import replay_hooks  # noqa: E402
from aaai_cli.show import show  # noqa: E402
from aaai_cli.study import study as study_group  # noqa: E402
from aaai_cli.validate import validate  # noqa: E402

cli.add_command(play_command)
cli.add_command(show)
cli.add_command(study_group)
cli.add_command(validate)

if __name__ == "__main__":
    cli()
