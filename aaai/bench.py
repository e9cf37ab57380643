"""`aaai bench`: steps per second against the physics limit and a peer, reset times, workers, memory.

Everything is measured in one run on one machine, so the ratios compare like with like.
- limit: a bare PyBullet loop over the very world an episode builds (same bodies, timestep,
  substeps and motor commands, reading the same joint states), no environment around it;
- the environment per level with four sensor settings; reset time per level;
- throughput with 1, 2 and 4 worker processes (Gymnasium's AsyncVectorEnv);
- the peer: Gymnasium's MuJoCo Ant-v5 with random actions (needs the `bench` extra);
- peak memory, and memory growth over 20,000 steps with a reset every 200.
"""
from __future__ import annotations

import json
import platform
import resource
import time
from pathlib import Path

import numpy as np
import pybullet as p

from aaai.env import AnimalAIEnv
from aaai.files import write_atomic
from aaai.levels import all_levels, get_level
from aaai.runs import package_versions

SENSOR_SETTINGS = {
    "joints": dict(rays=False, camera=False),
    "joints+rays": dict(rays=True, rays_per_side=8, camera=False),
    "joints+cam64rgb": dict(rays=False, camera=True, camera_resolution=64, camera_grayscale=False),
    "joints+cam84gray": dict(rays=False, camera=True, camera_resolution=84, camera_grayscale=True),
}


def _actions(n_axes: int, steps: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (steps, n_axes)).astype(np.float32)


def _timed_episode_steps(env, actions, seed: int) -> float:
    """Steps per second of env.step over ``actions`` in the world of ``seed`` (the limit's world);
    an episode that ends is reset, untimed, to the same seed."""
    env.reset(seed=seed)
    elapsed = 0.0
    for action in actions:
        started = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(action)
        elapsed += time.perf_counter() - started
        if terminated or truncated:
            env.reset(seed=seed)
    return len(actions) / elapsed


def limit_rate(level: int, steps: int, difficulty: int = 5) -> float:
    """The bare loop: motor command, stepSimulation, joint states; on the world an episode builds."""
    env = AnimalAIEnv(level=level, difficulty=difficulty, rays=False, max_steps=10000)
    env.reset(seed=0)
    body, c = env.body, env.client
    actions = _actions(body.n_axes, steps)
    targets = body.lower + (actions + 1.0) * 0.5 * (body.upper - body.lower)
    forces = [body.max_force] * body.n_axes
    kp, kd = [body.position_gain] * body.n_axes, [body.velocity_gain] * body.n_axes
    started = time.perf_counter()
    for target in targets:
        p.setJointMotorControlArray(body.id, body.joint_ids, p.POSITION_CONTROL, targetPositions=target.tolist(),
                                    forces=forces, positionGains=kp, velocityGains=kd, physicsClientId=c)
        p.stepSimulation(physicsClientId=c)
        p.getJointStates(body.id, body.joint_ids, physicsClientId=c)
    rate = steps / (time.perf_counter() - started)
    env.close()
    return rate


def env_rate(level: int, sensors: dict, steps: int) -> float:
    env = AnimalAIEnv(level=level, difficulty=5, max_steps=10000, **sensors)
    rate = _timed_episode_steps(env, _actions(env.body.n_axes, steps), seed=0)
    env.close()
    return rate


def hole_casting_rates(level: int, steps: int) -> dict | None:
    """Steps/s with rays on a level with missing floor, with the hole casting and without it (the
    rays as they were before they saw holes), in the same run; None for a level without holes."""
    rates = {}
    for name in ("with", "without"):
        env = AnimalAIEnv(level=level, difficulty=5, max_steps=10000, **SENSOR_SETTINGS["joints+rays"])
        env.reset(seed=0)
        if env.rays._holes is None:
            env.close()
            return None
        if name == "without":
            env.rays.set_holes = lambda rectangles: None  # never told of the holes: no casting
            env.rays._holes = None
        rates[name] = _timed_episode_steps(env, _actions(env.body.n_axes, steps), seed=0)
        env.close()
    return rates


def reset_times_ms(level: int, resets: int) -> tuple[float, float]:
    env = AnimalAIEnv(level=level, difficulty=5)
    env.reset(seed=0)  # warm-up
    times = []
    for seed in range(1, resets + 1):
        started = time.perf_counter()
        env.reset(seed=seed)
        times.append(1000 * (time.perf_counter() - started))
    env.close()
    return float(np.median(times)), float(np.percentile(times, 95))


def _make_l0() -> AnimalAIEnv:
    return AnimalAIEnv(level=0, rays=False)


def workers_rate(workers: int, steps_per_worker: int) -> float:
    """Total steps/s of L0 (joints only) in ``workers`` processes through AsyncVectorEnv."""
    from gymnasium.vector import AsyncVectorEnv

    envs = AsyncVectorEnv([_make_l0] * workers, context="forkserver")
    envs.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps_per_worker, workers, 8)).astype(np.float32)
    for action in actions[:50]:  # warm-up
        envs.step(action)
    started = time.perf_counter()
    for action in actions:
        envs.step(action)
    rate = steps_per_worker * workers / (time.perf_counter() - started)
    envs.close()
    return rate


def ant_rate(steps: int) -> float | None:
    try:
        import gymnasium as gym

        env = gym.make("Ant-v5")
    except Exception:  # mujoco (the `bench` extra) is missing
        return None
    env.action_space.seed(0)
    rate = _timed_episode_steps(env, [env.action_space.sample() for _ in range(steps)], seed=0)
    env.close()
    return rate


def _rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        pages = int(handle.read().split()[1])
    return pages * resource.getpagesize() / 2**20


def memory_growth(steps: int = 20000, reset_every: int = 200) -> dict:
    env = AnimalAIEnv(level=1, difficulty=5, rays=True)
    actions = _actions(env.body.n_axes, steps)
    env.reset(seed=0)
    for i, action in enumerate(actions[:2000]):  # warm-up: allocator pools fill
        env.step(action)
        if (i + 1) % reset_every == 0:
            env.reset(seed=i)
    before = _rss_mb()
    for i, action in enumerate(actions):
        env.step(action)
        if (i + 1) % reset_every == 0:
            env.reset(seed=10_000 + i)
    after = _rss_mb()
    env.close()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"rss_before_mb": before, "rss_after_mb": after, "growth": (after - before) / before, "peak_mb": peak}


def run(levels: list[int] | None = None, steps: int = 3000, resets: int = 50, worker_steps: int = 2000,
        memory_steps: int = 20000, log=print) -> dict:
    levels = levels if levels is not None else list(all_levels())
    results: dict = {"machine": _machine(), "settings": {"steps": steps, "resets": resets,
                                                          "worker_steps": worker_steps, "memory_steps": memory_steps}}
    log("limit (bare PyBullet loop) ...")
    results["limit"] = {get_level(level).label: limit_rate(level, steps) for level in levels}
    results["env"] = {}
    for level in levels:
        label = get_level(level).label
        log(f"{label} ...")
        results["env"][label] = {name: env_rate(level, sensors, steps) for name, sensors in SENSOR_SETTINGS.items()}
        holes = hole_casting_rates(level, steps)
        if holes:
            results.setdefault("hole_casting", {})[label] = holes
        median, p95 = reset_times_ms(level, resets)
        results["env"][label]["reset_median_ms"] = median
        results["env"][label]["reset_p95_ms"] = p95
    log("workers ...")
    results["workers"] = {str(n): workers_rate(n, worker_steps) for n in (1, 2, 4)}
    log("Ant-v5 ...")
    results["ant_v5"] = ant_rate(steps)
    log("memory ...")
    results["memory"] = memory_growth(memory_steps)
    results["ratios"] = ratios(results)
    return results


def ratios(results: dict) -> dict:
    env, limit = results["env"], results["limit"]
    out = {f"{level} joints / limit": env[level]["joints"] / limit[level] for level in env}
    out.update({f"{level} rays overhead": env[level]["joints"] / env[level]["joints+rays"] - 1 for level in env})
    if results["ant_v5"] and "L0" in env:
        out["L0 joints / Ant-v5"] = env["L0"]["joints"] / results["ant_v5"]
    out["2 workers / 1"] = results["workers"]["2"] / results["workers"]["1"]
    out["4 workers / 1"] = results["workers"]["4"] / results["workers"]["1"]
    return out


def _machine() -> dict:
    import os

    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "versions": package_versions()}


def markdown(results: dict) -> str:
    m = results["machine"]
    lines = [f"Machine: {m['platform']}, {m['cpus']} CPUs; Python {m['versions']['python']}, "
             f"pybullet {m['versions']['pybullet']}. Settings: {results['settings']}.", "",
             "| level | limit | joints | joints/limit | +rays | rays overhead | +cam 64 RGB | +cam 84 gray "
             "| reset median ms | reset p95 ms |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for level, row in results["env"].items():
        limit = results["limit"][level]
        lines.append(f"| {level} | {limit:.0f} | {row['joints']:.0f} | {row['joints'] / limit:.2f} | "
                     f"{row['joints+rays']:.0f} | {100 * (row['joints'] / row['joints+rays'] - 1):+.0f}% | "
                     f"{row['joints+cam64rgb']:.0f} | {row['joints+cam84gray']:.0f} | "
                     f"{row['reset_median_ms']:.1f} | {row['reset_p95_ms']:.1f} |")
    for level, rates in results.get("hole_casting", {}).items():
        lines.append(f"- {level} rays seeing holes: {rates['with']:.0f} steps/s; the same rays without the hole "
                     f"casting: {rates['without']:.0f} steps/s ({100 * (rates['without'] / rates['with'] - 1):+.0f}% "
                     "for seeing holes)")
    workers = results["workers"]
    ant = results["ant_v5"]
    memory = results["memory"]
    lines += ["", "All figures are steps per second of one process unless said.", "",
              f"- Workers (L0 joints, AsyncVectorEnv): 1: {workers['1']:.0f}, 2: {workers['2']:.0f}, "
              f"4: {workers['4']:.0f} steps/s; 2 / 1 = {workers['2'] / workers['1']:.2f}",
              f"- Ant-v5 (MuJoCo, random actions): " + (f"{ant:.0f} steps/s; L0 joints / Ant-v5 = "
                                                        f"{results['ratios']['L0 joints / Ant-v5']:.2f}"
                                                        if ant else "not measured (install the bench extra)"),
              f"- Memory: peak {memory['peak_mb']:.0f} MB; RSS {memory['rss_before_mb']:.1f} -> "
              f"{memory['rss_after_mb']:.1f} MB over {results['settings']['memory_steps']} steps with a reset "
              f"every 200 ({100 * memory['growth']:+.1f}%)"]
    return "\n".join(lines) + "\n"


def write(results: dict, folder: Path) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    json_path, md_path = folder / "bench.json", folder / "bench.md"
    write_atomic(json_path, json.dumps(results, indent=2) + "\n")
    write_atomic(md_path, markdown(results))
    return json_path, md_path
