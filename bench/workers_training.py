"""PPO (stable-baselines3) with its 8 environments in 2 worker processes of 4 against the same 8
in-process, alternated.

Four runners of the shipped training config, built once and timed in turn each round (the order
rotated; aaai.tools.bench's method): the environment alone (random actions, nothing else)
in-process and in 2 worker processes of 4 (``train.vector: async``, ``train.processes: 2``), and
PPO through the training loop both ways. PPO learns the same weights both ways
(tests/test_vector.py); only the time differs. Writes bench/workers_training.json and
bench/workers_training.md (``--report`` rewrites the .md from the .json).

    .venv/bin/python bench/workers_training.py --rounds 3 --steps 4096
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from aaai.files import write_atomic

OUT = Path(__file__).resolve().parent


def measure(rounds: int, steps: int) -> dict:
    from aaai.config import load_config
    from aaai.tools.bench import _PPOLoop, _VecLoop, training_config
    from aaai.tools.rounds import per_round, run_group, summary

    sync = training_config({"train": {"vector": "sync"}})
    workers = load_config(sync, vector="async", processes=2)
    with tempfile.TemporaryDirectory(prefix="aaai-workers-training-") as folder:
        runners = {
            "env alone, in-process": _VecLoop(sync, False, steps),
            "env alone, 2 x 4": _VecLoop(workers, True, steps),
            "PPO, in-process": _PPOLoop(sync, steps, Path(folder) / "sync"),
            "PPO, 2 x 4": _PPOLoop(workers, steps, Path(folder) / "async"),
        }
        rates, machine_load = run_group(runners, rounds)
    ratios = {
        "PPO 2 x 4 / PPO in-process": per_round(rates["PPO, 2 x 4"], rates["PPO, in-process"]),
        "env alone 2 x 4 / in-process": per_round(rates["env alone, 2 x 4"], rates["env alone, in-process"]),
        "PPO in-process / env alone in-process": per_round(rates["PPO, in-process"], rates["env alone, in-process"]),
        "PPO 2 x 4 / env alone in-process": per_round(rates["PPO, 2 x 4"], rates["env alone, in-process"]),
    }
    return {
        "rounds": rounds,
        "steps": steps,
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "load": machine_load,
    }


def report(results: dict) -> str:
    def figure(f: dict, digits: int = 0) -> str:
        return f"{f['median']:.{digits}f} ({f['min']:.{digits}f}..{f['max']:.{digits}f})"

    lines = [
        "# PPO with 2 worker processes of 4 environments against 8 in-process",
        "",
        f"The shipped training config (8 x 256, rays and the body senses, L0 d0-2); {results['rounds']} alternated "
        f"rounds of {results['steps']} steps; load {results['load']['before']} -> {results['load']['after']}.",
        "",
        "| | steps/s (median, min..max) |",
        "|---|---:|",
        *(f"| {name} | {figure(f)} |" for name, f in results["rates"].items()),
        "",
        *(f"- {name}: {figure(f, 2)}" for name, f in results["ratios"].items()),
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--report", action="store_true", help="rewrite the .md from the .json, measuring nothing")
    args = parser.parse_args()
    path = OUT / "workers_training.json"
    if args.report:
        results = json.loads(path.read_text())
    else:
        results = measure(args.rounds, args.steps)
        write_atomic(path, json.dumps(results, indent=2) + "\n")
    text = report(results)
    write_atomic(OUT / "workers_training.md", text)
    print(text)


if __name__ == "__main__":
    main()
