"""Where a joints-only `env.step` goes, per level, against the bare loop (`aaai bench`'s limit).

Each environment (difficulty 5, seed 0, rays off: the bench's "joints" figure) has its parts'
methods wrapped with a timer: the physics step (`Simulation.step`), the motor command
(`Body.apply`), the contact read (`Body.contacts`), the joint read and its normalisation
(`Body.joint_state`), the blow-up guard with its base-velocity read (`Body.blew_up`), the task's
contact bookkeeping (`Task.after_step`) and reward (`Task.get_reward`), the moving parts
(`World.advance`), the observation (`senses.observe`) and the info dict (`_info`); the rest of
`env.step` (action checks, the base-pose read, termination, bookkeeping) is what is left of the
step's time. The bare loop of the same world is timed alongside. Levels are taken in turn each
round (the order rotated); figures are medians over rounds, in microseconds per step (each timer
adds about 0.1-0.2 us). Writes bench/step_budget.md.

    .venv/bin/python bench/step_budget.py --rounds 3 --steps 3000
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

from aaai.levels import all_levels
from aaai.tools.bench import BareLoop, EnvLoop, _env

OUT = Path(__file__).resolve().parent
PARTS = {
    "physics step": ("sim", "step"),
    "motor command": ("body", "apply"),
    "contacts": ("body", "contacts"),
    "joint read": ("body", "joint_state"),
    "guard": ("body", "blew_up"),
    "contact bookkeeping": ("task", "after_step"),
    "reward": ("task", "get_reward"),
    "moving parts": ("world", "advance"),
    "observation": ("senses", "observe"),
    "info": (None, "_info"),
}


def wrap(env, spent: dict, owners: tuple[str | None, ...]) -> None:
    """Times the parts whose owner is in ``owners``; the world is built anew at each reset, so
    its part is wrapped again after every reset."""
    for part, (owner_name, method) in PARTS.items():
        if owner_name not in owners:
            continue
        owner = env if owner_name is None else getattr(env, owner_name)
        inner = getattr(owner, method)

        def timed(*args, _inner=inner, _part=part, **kwargs):
            start = time.perf_counter()
            try:
                return _inner(*args, **kwargs)
            finally:
                spent[_part] += time.perf_counter() - start

        setattr(owner, method, timed)
    if "world" in owners:
        return
    reset = env.reset

    def reset_and_wrap(*args, **kwargs):
        result = reset(*args, **kwargs)
        wrap(env, spent, ("world",))
        return result

    env.reset = reset_and_wrap


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args()
    levels = sorted(all_levels())
    labels = {i: all_levels()[i].label for i in levels}
    loops, bare, spent = {}, {}, {}
    for level in levels:
        env = _env(level, {"rays": False})
        spent[level] = dict.fromkeys(PARTS, 0.0)
        wrap(env, spent[level], tuple({owner for owner, _ in PARTS.values()} - {"world"}))
        loops[level] = EnvLoop(env, args.steps)
        bare[level] = BareLoop(level, args.steps)
    figures: dict[int, dict[str, list[float]]] = {level: {} for level in levels}
    load_before = os.getloadavg()
    for round_ in range(args.rounds):
        order = levels[round_ % len(levels) :] + levels[: round_ % len(levels)]
        for level in order:
            limit = bare[level]()
            for part in spent[level]:
                spent[level][part] = 0.0
            rate = loops[level]()
            step_us = 1e6 / rate
            row = {"limit": 1e6 / limit, "env.step": step_us}
            row.update({part: seconds / args.steps * 1e6 for part, seconds in spent[level].items()})
            row["rest of env.step"] = step_us - sum(spent[level].values()) / args.steps * 1e6
            for key, value in row.items():
                figures[level].setdefault(key, []).append(value)
    load_after = os.getloadavg()
    columns = ["limit", "env.step", *PARTS, "rest of env.step"]
    lines = [
        "# Where a joints-only step goes, per level (microseconds per step)",
        "",
        f"`bench/step_budget.py`: difficulty 5, seed 0, random actions; {args.rounds} rounds x {args.steps} steps"
        f" per level, levels alternated; load average {[round(v, 1) for v in load_before]} before,"
        f" {[round(v, 1) for v in load_after]} after. Medians over rounds. `limit`: the bare loop"
        " (motor command, stepSimulation, joint states) on the same world.",
        "",
        "| level | " + " | ".join(columns) + " | joints / limit | env.step beyond the physics step |",
        "|---|" + "---:|" * (len(columns) + 2),
    ]
    for level in levels:
        median = {key: statistics.median(values) for key, values in figures[level].items()}
        cells = [f"{median[key]:.1f}" for key in columns]
        ratio = median["limit"] / median["env.step"]
        beyond = median["env.step"] - median["physics step"]
        lines.append(f"| {labels[level]} | " + " | ".join(cells) + f" | {ratio:.2f} | {beyond:.1f} |")
    (OUT / "step_budget.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    for level in levels:
        loops[level].close()
        bare[level].close()


if __name__ == "__main__":
    main()
