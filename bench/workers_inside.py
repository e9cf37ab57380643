"""Where a worker process's CPU goes: its environments' step against the whole process, per step.

Steps the training vector env (the shipped config without rays, L0 d0-2, random actions) in 2
worker processes of ``--per-worker`` environments, and times inside each worker the CPU of its
environments' step (``SyncVectorEnv.step``) against the whole process's, per environment step;
then the same environments stepped in-process, the whole step's CPU (bookkeeping included). The
difference inside a worker is what a message costs it: receiving the actions, writing the
observations to shared memory, sending the rewards and flags, waking up. Prints the figures.

    .venv/bin/python bench/workers_inside.py --per-worker 8 --steps 1000
"""

from __future__ import annotations

import argparse
import os
import time

import aaai.train.workers as workers


class TimedGroup(workers.EnvGroup):
    """An EnvGroup that counts the CPU time of its environments' steps."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.inner, self.steps = 0.0, 0

    def step(self, action):
        started = time.process_time()
        result = super().step(action)
        self.inner += time.process_time() - started
        self.steps += self.size
        return result

    def timing(self) -> tuple[float, int, float]:
        return self.inner, self.steps, time.process_time()


def _timed_group(makers, first):
    return TimedGroup(makers, first)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--per-worker", type=int, default=8)
    parser.add_argument("--steps", type=int, default=1000)
    args = parser.parse_args()
    workers._group = _timed_group  # what the worker processes build (they import this module's copy)
    from aaai.tools.bench import training_config
    from aaai.tools.workers_bench import VectorRunner

    config = training_config({"sensors": {"rays": False}})
    k = args.per_worker
    print(f"load {os.getloadavg()}")
    runner = VectorRunner(config, 2 * k, 2, args.steps)
    runner(100)
    before = runner.vec.envs.envs.call("timing")
    runner()
    after = runner.vec.envs.envs.call("timing")
    for index, (b, a) in enumerate(zip(before, after)):
        n = a[1] - b[1]
        print(
            f"worker {index} ({k} environments): their step {1e6 * (a[0] - b[0]) / n:.1f} us, "
            f"the whole process {1e6 * (a[2] - b[2]) / n:.1f} us of CPU a step"
        )
    runner.close()
    alone = VectorRunner(config, k, 0, args.steps)
    alone(100)
    alone()
    print(f"{k} in-process: {alone.cpu[-1]['main_us']:.1f} us of CPU a step, bookkeeping included")
    alone.close()
    print(f"load {os.getloadavg()}")


if __name__ == "__main__":
    main()
