"""``aaai run``: episodes of a policy, a line each; ``--replay``: a recorded episode again, bit for bit."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ACTION_MODES, ConfigError
from aaai.env import AnimalAIEnv
from aaai.levels import SEED_LIMIT, get_level
from aaai.scoring.episodes import play
from aaai.scoring.policies import resolve

from .options import COUNT, POLICY_HELP, SEED, TRUST_HELP, parse_levels, parse_range, rule


@click.command("run")
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
    type=click.Choice(ACTION_MODES),
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
                load_arena(arena, seed + episode, body=env.config.agent.body)  # for the body's footprint
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


def run_episode(env: AnimalAIEnv, level: int | None, difficulty: int | None, seed: int, policy) -> str:
    """Plays one episode to its end; its line of the `aaai run` table. With level None, the env's
    arena file."""
    result = play(env, policy, seed, options=None if level is None else {"level": level, "difficulty": difficulty})
    info = result.info
    rate = info["steps"] / max(result.step_seconds, 1e-9)
    if level is None:
        assert env.arena is not None, "without a level the env plays its arena file"
        name, difficulty = Path(env.arena).name, info["difficulty"]
    else:
        name = f"{get_level(level).label} {info['level_name']}"
    return (
        f"{name:<20} {difficulty:>4} {seed:>6} {result.episode_return:>8.3f} {info['max_reward']:>6.2f} "
        f"{info['steps']:>6} {info['food_eaten']:>4} {info['wall_hits']:>5} {result.end:<10} {rate:>8.0f}"
    )


def run_replay_file(path: str, arena: str | None = None) -> None:
    """``aaai run --replay FILE``: the recorded episode again, its line of the run table, and
    whether it ended exactly as recorded (exit status 1 if not)."""
    from aaai.scoring.replays import load_replay, run_replay

    try:
        replay = load_replay(path)
        outcome = run_replay(replay, arena=arena)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    result, pose = outcome.result, outcome.final_pose
    where = replay["arena"]["name"] if replay["arena"] else f"L{replay['level']} {replay['level_name']}"
    click.echo(
        f"replay {path}: {replay['policy']} on {where}, difficulty {replay['difficulty']}, seed {replay['seed']}"
    )
    click.echo(
        f"steps {result.steps}  return {result.episode_return!r}  food {result.info['food_eaten']}  "
        f"end {result.end}  final pose x {pose['x']!r} y {pose['y']!r} z {pose['z']!r} yaw {pose['yaw']!r}"
    )
    if outcome.differences:
        raise click.ClickException(
            "the replay does not reproduce the recorded episode: " + "; ".join(outcome.differences)
        )
    click.echo("reproduced bit for bit: the same steps, return and final pose as recorded")
