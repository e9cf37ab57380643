"""`aaai bench`'s row for worker processes x environments per worker.

The training vector env (aaai.train.vector, random actions, nothing else) stepped four ways, built
once and alternated round by round (aaai.tools.bench's method):

- ``K in-process``: K environments in this process (``train.vector: sync``);
- ``1 x K``: the same K in one worker process;
- ``2 x K``: 2K environments in 2 worker processes, K each (aaai.train.workers);
- ``2K x 1``: 2K environments, one process each (as worker processes stepped before).

``aaai bench`` times the first and the third (K = 4); bench/workers_speed.py all four.

Besides steps per second, each runner's CPU time per environment step is taken, in this process
and in its worker processes (from /proc on Linux), from which docs/speed.md works out what the
design gives on more cores.
"""

from __future__ import annotations

import os
import time
from typing import Any, Mapping

import numpy as np

from aaai.config import Config
from aaai.tools.rounds import per_round, run_group, summary

ROUNDS_DEFAULT = 5


def _cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of process ``pid`` so far (None where /proc cannot tell)."""
    try:
        with open(f"/proc/{pid}/stat") as handle:
            fields = handle.read().rpartition(")")[2].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class VectorRunner:
    """The training vector of ``config`` with ``num_envs`` environments in ``processes`` worker
    processes (0: in this process), random actions; each call steps it ``steps`` times."""

    def __init__(self, config: Config, num_envs: int, processes: int, steps: int):
        from aaai.config import load_config
        from aaai.train.curriculum import Curriculum
        from aaai.train.vector import CurriculumVecEnv

        settings = load_config(config, num_envs=num_envs, processes=max(processes, 1))
        self.vec = CurriculumVecEnv(settings, Curriculum.from_config(settings), num_envs, asynchronous=processes > 0)
        self.steps = steps
        self.rng = np.random.default_rng(settings.train.seed)
        self.shape = (num_envs, *np.shape(self.vec.single_action_space.sample()))
        self.vec.reset()
        self.cpu: list[dict[str, float | None]] = []

    def _worker_cpu(self) -> float | None:
        envs = self.vec.envs
        if not hasattr(envs, "processes"):
            return 0.0
        seconds = [_cpu_seconds(process.pid) for process in envs.processes]
        return None if any(s is None for s in seconds) else sum(s for s in seconds if s is not None)

    def __call__(self, steps: int | None = None) -> float:
        n = steps or self.steps
        actions = self.rng.uniform(-1.0, 1.0, (n, *self.shape)).astype(np.float32)
        workers_before, cpu_before = self._worker_cpu(), time.process_time()
        started = time.perf_counter()
        for action in actions:
            self.vec.step(action)
        elapsed = time.perf_counter() - started
        cpu, workers_after = time.process_time() - cpu_before, self._worker_cpu()
        env_steps = n * self.vec.num_envs
        if steps is None:  # a timed round (not the warm-up)
            worker = None if workers_before is None or workers_after is None else workers_after - workers_before
            self.cpu.append(
                {"main_us": 1e6 * cpu / env_steps, "workers_us": None if worker is None else 1e6 * worker / env_steps}
            )
        return env_steps / elapsed

    def close(self) -> None:
        self.vec.close()


def runners(config: Config, per_worker: int, steps: int, full: bool = True) -> dict[str, VectorRunner]:
    """K in-process and 2 x K; with ``full`` also 1 x K and 2K x 1."""
    k = per_worker
    built = {f"{k} in-process": VectorRunner(config, k, 0, steps), f"2 x {k}": VectorRunner(config, 2 * k, 2, steps)}
    if full:
        built[f"1 x {k}"] = VectorRunner(config, k, 1, steps)
        built[f"{2 * k} x 1"] = VectorRunner(config, 2 * k, 2 * k, steps)
    return built


def workers_rates(
    per_worker: int = 4,
    steps: int = 500,
    rounds: int = ROUNDS_DEFAULT,
    config: Mapping[str, Any] | None = None,
    full: bool = True,
) -> dict:
    """Steps per second of the four vectors (above; without ``full`` K in-process and 2 x K only),
    alternated over ``rounds`` of ``steps`` vector steps each; their ratios round by round and
    their CPU time per environment step."""
    from aaai.config import load_config
    from aaai.train.training import with_proprioception

    settings = with_proprioception(load_config(config))  # as aaai train runs it (aaai.tools.bench.training_config)
    k = per_worker
    built = runners(settings, k, steps, full)
    rates, machine_load = run_group(built, rounds)
    ratios = {f"2 x {k} / {k} in-process": per_round(rates[f"2 x {k}"], rates[f"{k} in-process"])}
    if full:
        ratios[f"1 x {k} / {k} in-process"] = per_round(rates[f"1 x {k}"], rates[f"{k} in-process"])
        ratios[f"2 x {k} / {2 * k} x 1"] = per_round(rates[f"2 x {k}"], rates[f"{2 * k} x 1"])
    cpu: dict[str, dict] = {}
    for name, runner in built.items():
        cpu[name] = {}
        for part in ("main_us", "workers_us"):
            values = [c[part] for c in runner.cpu]
            known = [v for v in values if v is not None]
            if known and len(known) == len(values):
                cpu[name][part] = summary(known)
    sensors = [key.split(".")[1] for key, on in settings.flat().items() if key.startswith("sensors.") and on is True]
    return {
        "config": {
            "per_worker": k,
            "steps": steps,
            "levels": sorted(settings.curriculum.levels),
            "difficulties": sorted(settings.curriculum.difficulties),
            "sensors": sensors,
        },
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "cpu_us_per_step": cpu,
        "load": machine_load,
    }


def _figure(figure: dict, digits: int = 0) -> str:
    return f"{figure['median']:.{digits}f} ({figure['min']:.{digits}f}..{figure['max']:.{digits}f})"


def markdown(results: dict) -> str:
    """The row as a table: steps/s, CPU us per environment step here and in the workers, ratios."""
    c = results["config"]
    lines = [
        f"Workers x environments per worker ({', '.join(c['sensors'])}; levels {c['levels']}, difficulties "
        f"{c['difficulties']}; {c['steps']} vector steps a round; load {results['load']['before']} -> "
        f"{results['load']['after']}):",
        "",
        "| processes x environments | steps/s (median, min..max) | CPU us a step, this process | CPU us a step, "
        "worker processes |",
        "|---|---:|---:|---:|",
    ]
    for name, figure in results["rates"].items():
        cpu = results["cpu_us_per_step"].get(name, {})
        main = _figure(cpu["main_us"], 1) if "main_us" in cpu else ""
        workers = _figure(cpu["workers_us"], 1) if "workers_us" in cpu else ""
        lines.append(f"| {name} | {_figure(figure)} | {main} | {workers if not name.endswith('in-process') else ''} |")
    lines.append("")
    lines.append("- " + ", ".join(f"{name} = {_figure(figure, 2)}" for name, figure in results["ratios"].items()))
    return "\n".join(lines) + "\n"
