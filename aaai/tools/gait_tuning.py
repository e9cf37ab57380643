"""Measures the steerable gait and tunes its parameters with CMA-ES.

    python -m aaai.tools.gait_tuning --measure          # speeds of the shipped parameters
    python -m aaai.tools.gait_tuning --drive --evaluations 1800 --write   # re-tune gait and drive (make tune-gait)

The score of a parameter set is how fast the body, steered by ``aaai.sim.gait.approach`` straight at
each piece in turn, eats its way along random courses of food pieces (sizes 2 to 4) on flat
floor, with turns of any angle: the head must reach the food past the legs. Less a penalty for
every step the head touches the floor and for tipping over. ``--drive`` tunes the joint drive
(``agent.max_force``, ``position_gain``, ``velocity_gain``) too. CMA-ES comes from the ``cma``
package (the ``tune`` extra).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from aaai.config import config_dir, load_config
from aaai.errors import needs_extra
from aaai.levels import generate
from aaai.levels.common import arena_walls, sphere
from aaai.sim.gait import GaitParameters, SineGait, approach, load_parameters, steer
from aaai.spec import AgentPose, LevelSpec

COURSE_SECONDS = 30.0
TUNING_COURSES = 4  # courses the score averages over (drawn with seed 0) ...
MEASURED_COURSES = 10  # ... and the held-out ones --measure reports (seed 1)
REACHED = 2.0  # a waypoint without food counts as reached with the head this close
# Searched ranges: gait parameters, then (with --drive) log10 max_force, log10 position_gain, velocity_gain.
GAIT_RANGES = {
    "frequency": (0.5, 4.0),
    "stance_down": (-0.5, 1.0),
    "lift": (0.0, 1.5),
    "sweep": (0.1, 1.5),
    "turn_sweep": (0.1, 1.5),
    "sweep_lead": (-math.pi, math.pi),
    "crouch_stance": (-0.5, 1.0),
    "crouch_distance": (1.0, 8.0),
    "approach_speed": (0.1, 1.0),
}
DRIVE_RANGES = {"max_force": (1.0, 3.5), "position_gain": (-2.0, 0.0), "velocity_gain": (0.05, 2.0)}


def courses(count: int, seed: int) -> list[tuple[tuple[float, float, float], ...]]:
    """Courses of four yellow pieces (x, y, size 2, 3 or 4), each 8 to 20 from the last in a
    random direction (so turns of any angle), starting from the origin."""
    rng = np.random.default_rng(seed)
    drawn = []
    for _ in range(count):
        x, y, pieces = 0.0, 0.0, []
        for _ in range(4):
            angle, distance = rng.uniform(-math.pi, math.pi), rng.uniform(8.0, 20.0)
            x, y = x + distance * math.cos(angle), y + distance * math.sin(angle)
            pieces.append((float(x), float(y), float(rng.choice([2.0, 3.0, 4.0]))))
        drawn.append(tuple(pieces))
    return drawn


def course_speed(env, gait: SineGait, seed: int, count: int) -> tuple[float, float, float]:
    """Mean speed (units/s along the courses, eating every piece on the way), mean head-on-floor
    fraction and lowest uprightness over ``count`` courses."""
    results = [follow(env, gait, flat_arena(food=course), None, COURSE_SECONDS) for course in courses(count, seed)]
    return (
        float(np.mean([r["progress"] for r in results])) / COURSE_SECONDS,
        float(np.mean([r["ground"] for r in results])),
        min(r["upright"] for r in results),
    )


def flat_arena(size: float = 200.0, food=()) -> LevelSpec:
    """A flat arena, the agent at the centre facing +x, with yellow pieces (x, y, size)."""
    pieces = tuple(sphere("food_yellow", x, y, s) for x, y, s in food)
    return LevelSpec(
        level=0,
        name="flat",
        difficulty=0,
        seed=0,
        agent=AgentPose(0.0, 0.0, 0.0),
        objects=tuple(arena_walls((size, size), 4.0)) + pieces,
        arena_size=(size, size),
        max_food_reward=sum(piece.food_value for piece in pieces),
    )


def _pose(env) -> tuple[np.ndarray, float, float]:
    position, rotation = env.body.head_pose()
    return position, math.atan2(rotation[1, 0], rotation[0, 0]), rotation[2, 2]


def follow(env, gait: SineGait, spec: LevelSpec, waypoints, seconds: float) -> dict:
    """Steers the gait through waypoints (x, y) in turn, or to the spec's food pieces in turn
    (``waypoints`` None: each counts when eaten); returns the distance made good, the
    head-on-floor fraction and the lowest uprightness (z of the head's up axis)."""
    env.reset(options={"spec": spec})
    gait.reset()
    eat = waypoints is None
    if eat:
        waypoints = [food.position[:2] for food in spec.foods]
        radii = [food.size[0] / 2 for food in spec.foods]
    position, yaw, _ = _pose(env)
    legs = [math.dist(a, b) for a, b in zip([tuple(position[:2])] + list(waypoints[:-1]), waypoints)]
    done, target, ground, lowest = 0.0, 0, 0, 1.0
    steps = round(seconds / env.control_dt)
    info = {"food_eaten": 0}
    for _ in range(steps):
        x, y = position[:2]
        tx, ty = waypoints[target]
        distance = math.hypot(tx - x, ty - y)
        if (info["food_eaten"] > target) if eat else distance < REACHED:
            done += legs[target]
            target += 1
            if target == len(waypoints):
                break
            tx, ty = waypoints[target]
            distance = math.hypot(tx - x, ty - y)
        error = (math.atan2(ty - y, tx - x) - yaw + math.pi) % (2 * math.pi) - math.pi
        if eat:
            gait.command(*approach(gait.parameters, error, distance, radii[target]))
        else:
            gait.command(*steer(error, distance))
        _, _, terminated, truncated, info = env.step(gait())
        ground += info["reward_terms"]["ground"] != 0
        position, yaw, up = _pose(env)
        lowest = min(lowest, up)
        if eat and info["food_eaten"] == len(waypoints):  # the last piece ends the episode
            return {"progress": done + legs[target], "ground": ground / steps, "upright": lowest, "seconds": seconds}
        if terminated or truncated:  # fell or blew up
            return {"progress": done, "ground": 1.0, "upright": -1.0, "seconds": seconds}
    if target < len(waypoints):
        done += max(0.0, legs[target] - math.dist(position[:2], waypoints[target]))
    return {"progress": done, "ground": ground / steps, "upright": lowest, "seconds": seconds}


def open_loop(env, gait: SineGait, spec: LevelSpec, forward: float, turn: float, seconds: float = 10.0) -> dict:
    """Walks with fixed commands; returns the speed along the start heading and the turn rate."""
    env.reset(options={"spec": spec})
    gait.reset()
    gait.command(forward, turn)
    start, yaw0, _ = _pose(env)
    yaws, ground, steps = [yaw0], 0, round(seconds / env.control_dt)
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(gait())
        ground += info["reward_terms"]["ground"] != 0
        position, yaw, _ = _pose(env)
        yaws.append(yaw)
        if terminated or truncated:
            break
    facing = np.array([math.cos(yaw0), math.sin(yaw0)])
    return {
        "speed": float((position - start)[:2] @ facing) / seconds,
        "turn_rate": math.degrees(np.unwrap(yaws)[-1] - yaw0) / seconds,
        "ground": ground / steps,
    }


def terrain_speed(env, gait: SineGait, difficulty: int = 10, seeds=range(5), seconds: float = 10.0) -> float:
    """Mean speed (units/s) toward a point 100 ahead, steered, on L11's rough terrain."""
    speeds = []
    for seed in seeds:
        spec = generate(11, difficulty, seed)
        spec = LevelSpec(**{**spec.__dict__, "objects": tuple(o for o in spec.objects if not o.is_food)})
        agent = spec.agent
        far = (agent.x + 100 * math.cos(agent.yaw), agent.y + 100 * math.sin(agent.yaw))
        env.reset(options={"spec": spec})
        result = follow(env, gait, spec, [far], seconds)
        speeds.append(result["progress"] / seconds)
    return float(np.mean(speeds))


def measure(env, gait: SineGait) -> dict:
    flat = flat_arena()
    speed, ground, _ = course_speed(env, gait, seed=1, count=MEASURED_COURSES)
    ahead = follow(env, gait, flat, [(100.0, 0.0)], 10.0)
    return {
        "forward_speed": ahead["progress"] / 10.0,
        "forward_head_on_floor": ahead["ground"],
        "backward_speed": -open_loop(env, gait, flat, -1.0, 0.0)["speed"],
        "turn_rate_left": open_loop(env, gait, flat, 0.0, 1.0)["turn_rate"],
        "turn_rate_right": -open_loop(env, gait, flat, 0.0, -1.0)["turn_rate"],
        "course_speed": speed,  # eating every piece on the way
        "course_head_on_floor": ground,
        "terrain_speed_d10": terrain_speed(env, gait),
    }


def score(env, gait: SineGait) -> float:
    """To minimise: minus the course speed, plus penalties for the head on the floor and tipping."""
    speed, ground, upright = course_speed(env, gait, seed=0, count=TUNING_COURSES)
    return -speed + 10 * ground + (5.0 if upright < 0.6 else 0.0)


def tune(evaluations: int, drive: bool, seed: int, start: GaitParameters) -> tuple[GaitParameters, dict]:
    try:
        import cma  # type: ignore[import-untyped]  # cma ships no type information
    except ImportError as error:
        raise SystemExit(needs_extra(error, "tuning the gait")) from None

    from aaai.env import AnimalAIEnv

    ranges = {**GAIT_RANGES, **(DRIVE_RANGES if drive else {})}
    low, high = (np.array([r[i] for r in ranges.values()]) for i in (0, 1))

    def decode(z):
        values = dict(zip(ranges, low + (high - low) * np.clip(z, 0, 1)))
        gait = {k: float(v) for k, v in values.items() if k in GAIT_RANGES}
        drive_values = {
            k: float(10 ** values[k] if k != "velocity_gain" else values[k]) for k in DRIVE_RANGES if k in values
        }
        return GaitParameters(**{**start.to_dict(), **gait}), drive_values

    agent = load_config(None).agent
    start_values = {
        **start.to_dict(),
        **{k: math.log10(getattr(agent, k)) if k != "velocity_gain" else getattr(agent, k) for k in DRIVE_RANGES},
    }
    start_z = [(start_values[k] - lo) / (hi - lo) for k, (lo, hi) in ranges.items()]
    envs: dict = {}

    def objective(z) -> float:
        parameters, drive_values = decode(z)
        key = tuple(sorted(drive_values.items()))
        if key not in envs:
            for env in envs.values():
                env.close()
            envs.clear()
            envs[key] = AnimalAIEnv(rays=False, max_steps=10000, **drive_values)
        env = envs[key]
        return score(env, SineGait.for_env(env, parameters=parameters))

    es = cma.CMAEvolutionStrategy(
        np.clip(start_z, 0.05, 0.95), 0.1, {"seed": seed + 1, "popsize": 12, "maxfevals": evaluations, "verbose": -9}
    )
    while not es.stop():
        candidates = es.ask()
        es.tell(candidates, [objective(z) for z in candidates])
        best, drive_best = decode(es.result.xbest)
        print(f"generation {es.countiter}: best {es.result.fbest:.3f} {best.to_dict()} {drive_best}", flush=True)
    for env in envs.values():
        env.close()
    return decode(es.result.xbest)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--measure", action="store_true", help="only measure the shipped parameters")
    parser.add_argument("--evaluations", type=int, default=1500, help="CMA-ES evaluations (default 1500)")
    parser.add_argument("--drive", action="store_true", help="tune the joint drive as well")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--write",
        nargs="?",
        const=str(config_dir() / "gait.yaml"),
        metavar="PATH",
        help="write the result to PATH (default configs/gait.yaml)",
    )
    args = parser.parse_args(argv)
    from aaai.env import AnimalAIEnv

    parameters = load_parameters()
    drive_values: dict[str, Any] = {}  # env keywords (max_force, position_gain, velocity_gain); none when measuring
    if not args.measure:
        parameters, drive_values = tune(args.evaluations, args.drive, args.seed, parameters)
    env = AnimalAIEnv(rays=False, max_steps=10000, **drive_values)
    try:
        agent = load_config(None, **drive_values).agent
        print(
            yaml.safe_dump(
                {
                    "gait": {k: round(v, 4) for k, v in parameters.to_dict().items()},
                    "drive": {k: getattr(agent, k) for k in ("max_force", "position_gain", "velocity_gain")},
                },
                sort_keys=False,
            )
        )
        for name, value in measure(env, SineGait.for_env(env, parameters=parameters)).items():
            print(f"{name}: {value:.3f}")
    finally:
        env.close()
    if args.write:
        path = Path(args.write)
        text = yaml.safe_dump({k: round(v, 4) for k, v in parameters.to_dict().items()}, sort_keys=False)
        path.write_text(
            "# Written by `python -m aaai.tools.gait_tuning --write`: the shipped gait's parameters.\n" + text
        )
        print(f"wrote {path}" + (f"; set agent drive {drive_values} in configs/default.yaml" if drive_values else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
