"""`aaai bench`: steps per second against the physics limit and a peer, training against the
environment alone, reset times, workers, memory.

Every comparison is measured by alternation, in this one process: the things compared are built
once, then each of ``rounds`` rounds times a chunk of steps of each in turn (the order rotated
from round to round, so none is always first). A ratio is taken within a round, between figures
measured a moment apart, and reported as the median over the rounds with its spread (min..max).
On a shared machine a figure measured once, or each figure at a different moment, can mislead by
a factor of two; the load average before and after every part is recorded with the results.

- limit: a bare PyBullet loop over the very world an episode builds (same bodies, timestep,
  substeps and motor commands, reading the same joint states), no environment around it;
- the environment per level with four sensor settings, the rays also with rayTestBatch on 2
  threads, 1.0 wide (sensors.ray_width) and, on levels with missing floor, without the hole
  casting; reset time per level;
- throughput with 1, 2 and 4 worker processes (Gymnasium's AsyncVectorEnv) and 2 in-process;
- training: PPO and the random agent through the training loop, against the environment alone
  (the same vector env, workers and sensors, random actions, nothing else), for the shipped config;
- the peer: Gymnasium's MuJoCo Ant-v5 with random actions (needs the `bench` extra);
- peak memory, and memory growth over 20,000 steps with a reset every 200.

The figures are measured here (:func:`run`); :mod:`aaai.tools.bench_report` writes them as
``bench.json`` and the markdown table ``bench.md``.
"""

from __future__ import annotations

import os
import platform
import resource
import tempfile
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pybullet as p

from aaai.agent.body import Quadruped
from aaai.config import Config
from aaai.env import AnimalAIEnv
from aaai.levels import all_levels, get_level
from aaai.scoring.runs import package_versions
from aaai.tools.rounds import load, per_round, run_group, summary

SENSOR_SETTINGS: dict[str, dict[str, Any]] = {
    "joints": dict(rays=False, camera=False),
    "joints+rays": dict(rays=True, rays_per_side=8, camera=False),
    "joints+cam64rgb": dict(rays=False, camera=True, camera_resolution=64, camera_grayscale=False),
    "joints+cam84gray": dict(rays=False, camera=True, camera_resolution=84, camera_grayscale=True),
}
NO_HOLE_CASTING = "joints+rays without hole casting"
RAYS_TWO_THREADS = "joints+rays, rayTestBatch on 2 threads"
WIDE_RAYS = "joints+rays 1.0 wide"  # sensors.ray_width 1.0: three casts a ray (Animal-AI's 0.5 sphere casts)
SWEEP = "joints+rays+sweep memory"  # sensors.sweep_memory 8: the map of where the rays have looked, read each step
SWEEP_MAP = "joints+rays+sweep memory+map"  # and sensors.sweep_map 15: the same marks read as a 15 x 15 map


# --- what is timed ----------------------------------------------------------------------------
def _actions(n_axes: int, steps: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (steps, n_axes)).astype(np.float32)


class EnvLoop:
    """``env.step`` with random actions in the world of one seed (the limit's world); an episode
    that ends is reset, untimed, to the same seed. Each call times ``steps`` steps."""

    def __init__(self, env, steps: int, seed: int = 0):
        self.env, self.steps, self.seed = env, steps, seed
        self.actions = _actions(env.action_space.shape[0], steps)
        env.reset(seed=seed)

    def __call__(self, steps: int | None = None) -> float:
        env, elapsed = self.env, 0.0
        actions = self.actions[: steps or self.steps]
        for action in actions:
            started = time.perf_counter()
            _, _, terminated, truncated, _ = env.step(action)
            elapsed += time.perf_counter() - started
            if terminated or truncated:
                env.reset(seed=self.seed)
        return len(actions) / elapsed

    def close(self) -> None:
        self.env.close()


class BareLoop:
    """The limit: motor command, stepSimulation, joint states; on the world an episode builds."""

    def __init__(self, level: int, steps: int, difficulty: int = 5):
        self.env = env = AnimalAIEnv(level=level, difficulty=difficulty, rays=False, max_steps=10000)
        env.reset(seed=0)
        body = env.body
        assert isinstance(body, Quadruped)  # the default body: the bench measures its motors
        self.steps = steps
        self.targets = [
            t.tolist() for t in body.lower + (_actions(body.n_axes, steps) + 1.0) * 0.5 * (body.upper - body.lower)
        ]
        self.forces = [body.max_force] * body.n_axes
        self.kp, self.kd = [body.position_gain] * body.n_axes, [body.velocity_gain] * body.n_axes

    def __call__(self, steps: int | None = None) -> float:
        body, c = self.env.body, self.env.client
        targets = self.targets[: steps or self.steps]
        started = time.perf_counter()
        for target in targets:
            p.setJointMotorControlArray(
                body.id,
                body.joint_ids,
                p.POSITION_CONTROL,
                targetPositions=target,
                forces=self.forces,
                positionGains=self.kp,
                velocityGains=self.kd,
                physicsClientId=c,
            )
            p.stepSimulation(physicsClientId=c)
            p.getJointStates(body.id, body.joint_ids, physicsClientId=c)
        return len(targets) / (time.perf_counter() - started)

    def close(self) -> None:
        self.env.close()


def _env(level: int, sensors: dict, difficulty: int = 5) -> AnimalAIEnv:
    return AnimalAIEnv(level=level, difficulty=difficulty, max_steps=10000, **sensors)


def _without_hole_casting(env: AnimalAIEnv) -> AnimalAIEnv:
    """The rays as they were before they saw holes: never told of the level's missing floor."""
    rays = env.rays
    if rays is None:
        raise ValueError("the rays without hole casting need an environment with rays")
    setattr(rays, "set_holes", lambda rectangles: None)  # on this instance only: the level's holes never reach it
    rays._holes = None
    return env


def level_rates(level: int, steps: int, rounds: int) -> dict:
    """The bare loop, the four sensor settings (and the rays without hole casting on a level with
    missing floor) on one level, alternated; rates and per-round ratios."""
    runners: dict = {"limit": BareLoop(level, steps)}
    for name, sensors in SENSOR_SETTINGS.items():
        runners[name] = EnvLoop(_env(level, sensors), steps)
    runners[RAYS_TWO_THREADS] = EnvLoop(_env(level, SENSOR_SETTINGS["joints+rays"]), steps)
    runners[RAYS_TWO_THREADS].env.rays.threads = 2  # PyBullet's numThreads: the same hits, split over threads
    runners[WIDE_RAYS] = EnvLoop(_env(level, {**SENSOR_SETTINGS["joints+rays"], "ray_width": 1.0}), steps)
    runners[SWEEP] = EnvLoop(_env(level, {**SENSOR_SETTINGS["joints+rays"], "sweep_memory": 8}), steps)
    runners[SWEEP_MAP] = EnvLoop(
        _env(level, {**SENSOR_SETTINGS["joints+rays"], "sweep_memory": 8, "sweep_map": 15}), steps
    )
    if runners["joints+rays"].env.rays._holes is not None:
        runners[NO_HOLE_CASTING] = EnvLoop(_without_hole_casting(_env(level, SENSOR_SETTINGS["joints+rays"])), steps)
    rates, machine_load = run_group(runners, rounds)
    ratios = {
        "joints / limit": per_round(rates["joints"], rates["limit"]),
        "rays overhead": per_round(rates["joints"], rates["joints+rays"], minus_one=True),
        "rays overhead, 2 threads": per_round(rates["joints"], rates[RAYS_TWO_THREADS], minus_one=True),
        "wide rays overhead": per_round(rates["joints"], rates[WIDE_RAYS], minus_one=True),
        "sweep memory overhead": per_round(rates["joints+rays"], rates[SWEEP], minus_one=True),
        "sweep map overhead": per_round(rates[SWEEP], rates[SWEEP_MAP], minus_one=True),
    }
    if NO_HOLE_CASTING in rates:
        ratios["cost of seeing holes"] = per_round(rates[NO_HOLE_CASTING], rates["joints+rays"], minus_one=True)
    return {
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "load": machine_load,
    }


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


class VectorLoop:
    """Total steps/s of L0 (joints only) in ``workers`` environments: worker processes
    (AsyncVectorEnv) or this process (SyncVectorEnv)."""

    def __init__(self, workers: int, steps_per_worker: int, asynchronous: bool = True):
        from gymnasium.vector import AsyncVectorEnv, SyncVectorEnv

        makers = [_make_l0] * workers
        self.envs = AsyncVectorEnv(makers, context="forkserver") if asynchronous else SyncVectorEnv(makers)
        self.envs.reset(seed=0)
        self.workers, self.steps = workers, steps_per_worker
        self.actions = np.random.default_rng(0).uniform(-1, 1, (steps_per_worker, workers, 8)).astype(np.float32)

    def __call__(self, steps: int | None = None) -> float:
        actions = self.actions[: steps or self.steps]
        started = time.perf_counter()
        for action in actions:
            self.envs.step(action)
        return len(actions) * self.workers / (time.perf_counter() - started)

    def close(self) -> None:
        self.envs.close()


def workers_rates(steps_per_worker: int, rounds: int) -> dict:
    runners = {
        "1": VectorLoop(1, steps_per_worker),
        "2": VectorLoop(2, steps_per_worker),
        "4": VectorLoop(4, steps_per_worker),
        "2 in-process": VectorLoop(2, steps_per_worker, False),
    }
    rates, machine_load = run_group(runners, rounds)
    ratios = {
        "2 workers / 1": per_round(rates["2"], rates["1"]),
        "4 workers / 1": per_round(rates["4"], rates["1"]),
        "2 in-process / 2 workers": per_round(rates["2 in-process"], rates["2"]),
    }
    return {
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "load": machine_load,
    }


class _AntLoop(EnvLoop):
    def __init__(self, steps: int):
        import gymnasium as gym

        env = gym.make("Ant-v5")
        env.action_space.seed(0)
        super().__init__(env, steps)
        self.actions = np.array([env.action_space.sample() for _ in range(steps)])


def ant_rates(steps: int, rounds: int) -> dict | None:
    """Ant-v5 against L0 joints-only, alternated; None without MuJoCo (the `bench` extra)."""
    try:
        ant = _AntLoop(steps)
    except Exception:  # mujoco (the `bench` extra) is missing
        return None
    rates, machine_load = run_group(
        {"L0 joints": EnvLoop(_env(0, SENSOR_SETTINGS["joints"]), steps), "Ant-v5": ant}, rounds
    )
    return {
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {"L0 joints / Ant-v5": summary(per_round(rates["L0 joints"], rates["Ant-v5"]))},
        "load": machine_load,
    }


# --- training against the environment alone ---------------------------------------------------
class _VecLoop:
    """The training vector env alone: random actions, nothing else (``tracker`` None), or the
    random agent of ``aaai train --agent random`` (its loop: the tracker logs every episode)."""

    def __init__(self, config: Config, asynchronous: bool | None, steps: int, tracker_folder: Path | None = None):
        from aaai.train.curriculum import Curriculum
        from aaai.train.vector import CurriculumVecEnv

        curriculum = Curriculum.from_config(config)
        self.vec = CurriculumVecEnv(config, curriculum, config.train.num_envs, asynchronous=asynchronous)
        self.tracker = _tracker(config, curriculum, tracker_folder) if tracker_folder else None
        self.steps, self.done = steps, 0
        self.rng = np.random.default_rng(config.train.seed)
        self.shape = (self.vec.num_envs, *(self.vec.single_action_space.shape or ()))
        self.vec.reset()

    def __call__(self, steps: int | None = None) -> float:
        vec, n = self.vec, vec_steps(steps or self.steps, self.vec.num_envs)
        started = time.perf_counter()
        for _ in range(n):
            finished = vec.step(self.rng.uniform(-1.0, 1.0, self.shape).astype(np.float32))[4]
            self.done += vec.num_envs
            if self.tracker is not None:
                self.tracker.update(self.done, finished, dict)
        return n * vec.num_envs / (time.perf_counter() - started)

    def close(self) -> None:
        self.vec.close()


def vec_steps(steps: int, num_envs: int) -> int:
    return max(1, steps // num_envs)


def _tracker(config: Config, curriculum, folder: Path):
    from aaai.scoring.runs import RunFolder
    from aaai.train.training import Tracker

    run = RunFolder(folder)
    run.create(config)
    return Tracker(run, curriculum, config, 0)


class _PPOLoop:
    """PPO (stable-baselines3) as ``aaai train`` runs it: rollouts and updates; each call learns
    ``steps`` more steps (whole rollouts)."""

    def __init__(self, config: Config, steps: int, folder: Path):
        from stable_baselines3.common.vec_env import VecMonitor

        from aaai.train.curriculum import Curriculum
        from aaai.train.learner import CurriculumSB3Env, TrackerCallback, lean_torch, ppo_from_config
        from aaai.train.vector import CurriculumVecEnv

        lean_torch()  # as train_ppo
        curriculum = Curriculum.from_config(config)
        vec = CurriculumVecEnv(config, curriculum, config.train.num_envs)
        self.tracker = _tracker(config, curriculum, folder)
        self.env = CurriculumSB3Env(vec)
        self.model = ppo_from_config(VecMonitor(self.env), config, self.tracker.run)
        self.callback = TrackerCallback(self.env, self.tracker, lambda steps: None)
        self.rollout = config.train.n_steps * vec.num_envs
        self.steps, self.started = steps, False

    def __call__(self, steps: int | None = None) -> float:
        steps = max(self.rollout, (steps or self.steps) // self.rollout * self.rollout)
        before = self.model.num_timesteps
        started = time.perf_counter()
        self.model.learn(steps, callback=self.callback, reset_num_timesteps=not self.started, tb_log_name="bench")
        self.started = True
        return (self.model.num_timesteps - before) / (time.perf_counter() - started)

    def close(self) -> None:
        self.env.close()


def training_config(config: Mapping[str, Any] | None = None) -> Config:
    """The config ``aaai train`` runs by default: the shipped one with training's extra senses."""
    from aaai.config import load_config
    from aaai.train.training import with_proprioception

    return with_proprioception(load_config(config))


def training_rates(steps: int, rounds: int, config: Mapping[str, Any] | None = None, ppo: bool = True) -> dict:
    """PPO and the random agent (the training loop, the tracker logging episodes) against the
    environment alone (the same vector env of the same config, random actions, nothing else),
    in-process and in worker processes, alternated. ``steps`` per round; PPO rounds are whole
    rollouts of n_steps x num_envs."""
    from aaai.train.vector import runs_in_process

    settings = training_config(config)
    train = settings.train
    in_process = runs_in_process(train.vector, train.num_envs)
    with tempfile.TemporaryDirectory(prefix="aaai-bench-") as folder:
        runners: dict = {
            "env alone, in-process": _VecLoop(settings, False, steps),
            "env alone, worker processes": _VecLoop(settings, True, steps),
            "random agent": _VecLoop(settings, None, steps, Path(folder) / "random"),
        }
        if ppo:
            runners["PPO"] = _PPOLoop(settings, steps, Path(folder) / "ppo")
        rates, machine_load = run_group(runners, rounds)
    same = "env alone, in-process" if in_process else "env alone, worker processes"
    best = [max(a, b) for a, b in zip(rates["env alone, in-process"], rates["env alone, worker processes"])]
    ratios = {
        "random agent / env alone": per_round(rates["random agent"], rates[same]),
        "random agent / env alone (best)": per_round(rates["random agent"], best),
    }
    if ppo:
        ratios["PPO / env alone"] = per_round(rates["PPO"], rates[same])
        ratios["PPO / env alone (best)"] = per_round(rates["PPO"], best)
    sensors = [key.split(".")[1] for key, on in settings.flat().items() if key.startswith("sensors.") and on is True]
    return {
        "config": {
            "num_envs": train.num_envs,
            "vector": train.vector,
            "runs": "in-process" if in_process else "worker processes",
            "n_steps": train.n_steps,
            "n_epochs": train.n_epochs,
            "batch_size": train.batch_size,
            "net_width": train.net_width,
            "levels": sorted(settings.curriculum.levels),
            "difficulties": sorted(settings.curriculum.difficulties),
            "sensors": sensors,
        },
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "load": machine_load,
    }


# --- memory ---------------------------------------------------------------------------------
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


# --- the whole run ----------------------------------------------------------------------------
def run(
    levels: list[int] | None = None,
    steps: int = 1000,
    rounds: int = 5,
    resets: int = 50,
    worker_steps: int = 1000,
    train_steps: int = 4096,
    memory_steps: int = 20000,
    train_config: Mapping[str, Any] | None = None,
    log=print,
) -> dict:
    """Every figure; ``steps`` (per figure and round), ``worker_steps`` (per worker and round) and
    ``train_steps`` (per round; 0 leaves training out) set the size of each timed chunk;
    ``train_config`` overrides the shipped config for the training row."""
    levels = levels if levels is not None else list(all_levels())
    results: dict = {
        "machine": _machine(),
        "load": {"before": load()},
        "settings": {
            "rounds": rounds,
            "steps": steps,
            "resets": resets,
            "worker_steps": worker_steps,
            "train_steps": train_steps,
            "memory_steps": memory_steps,
        },
    }
    log("memory ...")  # first: the peak is this process's, before anything else is built
    results["memory"] = memory_growth(memory_steps)
    results["levels"] = {}
    for level in levels:
        label = get_level(level).label
        log(f"{label} ...")
        results["levels"][label] = level_rates(level, steps, rounds)
        median, p95 = reset_times_ms(level, resets)
        results["levels"][label]["reset_ms"] = {"median": median, "p95": p95}
    log("workers ...")
    results["workers"] = workers_rates(worker_steps, rounds)
    from aaai.tools import workers_bench  # processes x environments per worker (aaai.train.workers)

    results["worker_groups"] = workers_bench.workers_rates(4, max(1, worker_steps // 2), rounds, full=False)
    if train_steps:
        log("training ...")
        results["training"] = training_rates(train_steps, rounds, train_config)
    log("Ant-v5 ...")
    results["ant_v5"] = ant_rates(steps, rounds)
    results["load"]["after"] = load()
    results["ratios"] = ratios(results)
    return results


def ratios(results: dict) -> dict:
    """Every ratio's median over the rounds, by name."""
    out = {}
    for label, level in results["levels"].items():
        out.update({f"{label} {name}": value["median"] for name, value in level["ratios"].items()})
    for part in ("workers", "worker_groups", "training", "ant_v5"):
        if results.get(part):
            out.update({name: value["median"] for name, value in results[part]["ratios"].items()})
    return out


def _machine() -> dict:
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "versions": package_versions(),
    }
