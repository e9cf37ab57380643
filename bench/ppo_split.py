"""Where a PPO training step goes on the shipped config: the environment, the policy's forward
pass during collection, the update, and the rest (stable-baselines3's rollout bookkeeping,
the tracker).

Runs the bench's PPO loop (``aaai.tools.bench._PPOLoop``: ``aaai train``'s learner on the default
config) for ``--rounds`` rounds of ``--steps`` steps and times, inside it, the vector env's
``step`` (``CurriculumVecEnv.step``), the policy's forward pass (``policy.forward``) and
``PPO.train`` (the update). Writes bench/ppo_split.md.

    nice -n 10 .venv/bin/python bench/ppo_split.py --rounds 3 --steps 4096
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from aaai.tools.bench import _PPOLoop, training_config

OUT = Path(__file__).resolve().parent


def timed(owner, name: str, spent: dict, key: str) -> None:
    inner = getattr(owner, name)

    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[key] += time.perf_counter() - start

    setattr(owner, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=4096)
    args = parser.parse_args()
    config = training_config()
    spent = dict.fromkeys(("env", "forward", "update"), 0.0)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as folder:
        loop = _PPOLoop(config, args.steps, Path(folder) / "run")
        timed(loop.env.vec, "step", spent, "env")
        timed(loop.model.policy, "forward", spent, "forward")
        timed(loop.model, "train", spent, "update")
        loop(loop.rollout)  # a first rollout and update, untimed: torch's first calls
        rows = []
        for _ in range(args.rounds):
            for key in spent:
                spent[key] = 0.0
            before = loop.model.num_timesteps
            start = time.perf_counter()
            loop(args.steps)
            total = time.perf_counter() - start
            steps = loop.model.num_timesteps - before
            row = {key: value / steps * 1e6 for key, value in spent.items()}
            row["total"] = total / steps * 1e6
            row["rest"] = row["total"] - row["env"] - row["forward"] - row["update"]
            rows.append(row)
        loop.close()
    load_after = os.getloadavg()
    train = config.train
    lines = [
        "# Where a PPO training step goes (shipped config)",
        "",
        f"`bench/ppo_split.py`: {train.num_envs} environments x n_steps {train.n_steps},"
        f" {train.n_epochs} epochs, batch {train.batch_size}; {args.rounds} rounds of {args.steps}"
        f" steps; load average {[round(v, 1) for v in load_before]} before,"
        f" {[round(v, 1) for v in load_after]} after. Microseconds per environment step, median over"
        " rounds (min..max), and the share of the whole.",
        "",
        "| part | us per step | share |",
        "|---|---:|---:|",
    ]
    labels = {
        "env": "the environments (vector env step)",
        "forward": "the policy's forward pass while collecting",
        "update": "the PPO update (`PPO.train`)",
        "rest": "the rest (rollout buffer, VecMonitor, callback, tracker)",
        "total": "all",
    }
    for key, label in labels.items():
        values = [r[key] for r in rows]
        shares = [r[key] / r["total"] for r in rows]
        lines.append(
            f"| {label} | {statistics.median(values):.0f} ({min(values):.0f}..{max(values):.0f})"
            f" | {statistics.median(shares):.0%} |"
        )
    (OUT / "ppo_split.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
