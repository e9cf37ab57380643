"""The ``aaai`` command: run, inspect and list levels from the shell."""
from __future__ import annotations

import time

import click
import numpy as np

from aaai.config import ConfigError
from aaai.env import AnimalAIEnv
from aaai.gait import SineGait
from aaai.levels import all_levels, generate, get_level
from aaai.registration import level_env_id

POLICIES = ("random", "gait")


def parse_range(text: str, name: str, low: int, high: int) -> list[int]:
    """'0-3,5' -> [0, 1, 2, 3, 5], each checked to lie in low..high."""
    values: list[int] = []
    try:
        for part in text.split(","):
            first, _, last = part.strip().partition("-")
            values.extend(range(int(first), int(last or first) + 1))
    except ValueError:
        raise click.BadParameter(f"got {text!r}; allowed: numbers and ranges like '0-3,5'", param_hint=name) from None
    bad = [v for v in values if not low <= v <= high]
    if bad or not values:
        raise click.BadParameter(f"got {text!r}; allowed: values from {low} to {high}", param_hint=name)
    return sorted(set(values))


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
@click.option("-d", "--difficulty", type=int, default=0, show_default=True)
@click.option("-s", "--seed", type=int, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print the whole spec as JSON.")
def spec_command(level, difficulty, seed, as_json):
    """Print the level spec that (LEVEL, difficulty, seed) generates, and its hash."""
    try:
        spec = generate(get_level(level).id, difficulty, seed)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    if as_json:
        click.echo(spec.to_json())
        return
    click.echo(f"L{spec.level} {spec.name}  difficulty {spec.difficulty}  seed {spec.seed}")
    click.echo(f"agent at ({spec.agent.x:.2f}, {spec.agent.y:.2f}) heading {np.degrees(spec.agent.yaw):.0f} deg")
    for obj in spec.objects:
        x, y, z = obj.position
        moving = f"  {obj.behaviour['type']}" if obj.behaviour else ""
        click.echo(f"  {obj.kind:<16} {obj.shape:<8} at ({x:6.2f}, {y:6.2f}, {z:5.2f}) size {' x '.join(f'{v:.2f}' for v in obj.size)}{moving}")
    click.echo(f"max food reward {spec.max_food_reward:.3f}   hash {spec.digest()}")


@cli.command("run")
@click.option("--levels", "levels_text", default="0", show_default=True, help="Levels, e.g. '0-1' or '0,1'.")
@click.option("--difficulty", "difficulty_text", default="0", show_default=True, help="Difficulties, e.g. '0-4'.")
@click.option("--episodes", type=click.IntRange(1), default=1, show_default=True, help="Episodes per cell.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True, help="First episode seed.")
@click.option("--policy", type=click.Choice(POLICIES), default="random", show_default=True)
@click.option("--config", "config_path", type=click.Path(), help="A YAML overriding configs/default.yaml.")
@click.option("--max-steps", type=int, help="Episode length T (overrides the config).")
@click.option("--camera/--no-camera", default=None, help="Turn the head camera on or off.")
@click.option("--rays/--no-rays", default=None, help="Turn the rays on or off.")
def run_command(levels_text, difficulty_text, episodes, seed, policy, config_path, max_steps, camera, rays):
    """Run episodes with a random policy or the example gait and print a summary of each."""
    levels = parse_range(levels_text, "--levels", 0, 11)
    difficulties = parse_range(difficulty_text, "--difficulty", 0, 10)
    overrides = {k: v for k, v in dict(max_steps=max_steps, camera=camera, rays=rays).items() if v is not None}
    try:
        for level in levels:
            get_level(level)
        env = AnimalAIEnv(level=levels[0], config=config_path, **overrides)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    click.echo(f"{'level':<20} {'diff':>4} {'seed':>6} {'return':>8} {'max':>6} {'steps':>6} "
               f"{'food':>4} {'walls':>5} {'end':<10} {'steps/s':>8}")
    episode = 0
    for level in levels:
        for difficulty in difficulties:
            for _ in range(episodes):
                summary = run_episode(env, level, difficulty, seed + episode, policy)
                episode += 1
                click.echo(summary)
    env.close()


def run_episode(env: AnimalAIEnv, level: int, difficulty: int, seed: int, policy: str) -> str:
    observation, info = env.reset(seed=seed, options={"level": level, "difficulty": difficulty})
    env.action_space.seed(seed)
    gait = SineGait.for_env(env) if policy == "gait" else None
    total, started = 0.0, time.perf_counter()
    while True:
        action = gait(observation) if gait else env.action_space.sample()
        observation, reward, terminated, truncated, info = env.step(action)
        total += reward
        if terminated or truncated:
            break
    rate = info["steps"] / max(time.perf_counter() - started, 1e-9)
    end = "fell" if info["fell"] else "blew up" if info["blew_up"] else "ate green" if terminated else "time"
    name = f"L{level} {info['level_name']}"
    return (f"{name:<20} {difficulty:>4} {seed:>6} {total:>8.3f} {info['max_reward']:>6.2f} {info['steps']:>6} "
            f"{info['food_eaten']:>4} {info['wall_hits']:>5} {end:<10} {rate:>8.0f}")


if __name__ == "__main__":
    cli()
