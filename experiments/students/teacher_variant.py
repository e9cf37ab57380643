"""The searching reference with its exploration constants changed, on the reserved episodes, against it.

    python experiments/students/teacher_variant.py run '{"GAIN_WEIGHT": 120.0}' 5,0,2,4,8,9,12 A.csv
    python experiments/students/teacher_variant.py run '{"GAIN_WEIGHT": 120.0}' 1,3,6,7,10,11 B.csv
    python experiments/students/teacher_variant.py table bench/search_teacher_search_default.csv --against A.csv B.csv

``run`` sets the named constants of aaai.task.search (GAIN_WEIGHT, GAIN_SPAN, TURN_WEIGHT, ...) in this
process only and plays the teacher, in gait mode on the default senses, on the 110 reserved episodes of
each given level (10 seeds a difficulty, as ``aaai eval --seeds reserved -k 10``), one row an episode,
flushed as it goes. Passed: at least 80 % of the level's food reward eaten. ``table`` compares the
rows after ``--against`` with the rows before it (the teacher unchanged, played the same way; or a
scoreboard of ``aaai eval``), level by level: passes, episodes gained and lost, and the exact
two-sided sign test on them (McNemar's). Its actions are put on aaai eval's grid
(aaai.scoring.policies.on_grid), so that the unchanged teacher plays here what ``aaai eval --policy
search --action-mode gait`` plays.
"""

from __future__ import annotations

import csv
import json
import sys
from collections import defaultdict


def run(variant: dict, levels: list[int], out: str) -> None:
    import aaai.task.search as search
    from aaai.config import load_config
    from aaai.env import AnimalAIEnv
    from aaai.levels.seeds import reserved_seeds
    from aaai.scoring.policies import on_grid

    for name, value in variant.items():
        if not hasattr(search, name):
            raise SystemExit(f"variant: got {name!r}; allowed: a constant of aaai.task.search")
        setattr(search, name, value)
    env = AnimalAIEnv(config=load_config(None, action_mode="gait").env_dict())
    teacher = search.SearchController(env)
    with open(out, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["level", "difficulty", "seed", "passed", "steps"])
        for level in levels:
            for difficulty in range(11):
                for seed in reserved_seeds(level, difficulty, 10):
                    observation, info = env.reset(seed=seed, options={"level": level, "difficulty": difficulty})
                    teacher.reset(seed)
                    total = 0.0
                    while True:
                        action = on_grid(teacher(observation))  # as aaai eval hands it to the environment
                        observation, reward, terminated, truncated, info = env.step(action)
                        total += reward - info["reward_terms"].get("shaping", 0.0)
                        if terminated or truncated:
                            break
                    passed = info["max_reward"] > 0 and total / info["max_reward"] >= 0.8
                    writer.writerow([level, difficulty, seed, int(passed), info["steps"]])
                    handle.flush()
    env.close()


def table(base: list[str], rows: list[str]) -> None:
    from scipy.stats import binomtest

    before = {}
    for path in base:
        with open(path, newline="") as handle:
            for row in csv.DictReader(handle):
                key = int(row["level"]), int(row["difficulty"]), int(row["seed"])
                before[key] = row["passed"] == "1" if "passed" in row else row["outcome"] in ("succeeded", "passed")
    cells: dict[object, list[int]] = defaultdict(lambda: [0, 0, 0, 0, 0])
    for path in rows:
        with open(path, newline="") as handle:
            for row in csv.DictReader(handle):
                key = int(row["level"]), int(row["difficulty"]), int(row["seed"])
                old, new = before[key], row["passed"] == "1"
                for cell in (cells[key[0]], cells["all"]):
                    cell[0] += 1
                    cell[1] += old
                    cell[2] += new
                    cell[3] += new and not old
                    cell[4] += old and not new
    print("| level | episodes | the searching reference | the variant | gained / lost | sign test p |")
    print("|---|---:|---:|---:|---:|---:|")
    for key in sorted((k for k in cells if k != "all"), key=int) + ["all"]:
        n, old, new, gained, lost = cells[key]
        p = binomtest(gained, gained + lost).pvalue if gained + lost else 1.0
        name = "**all**" if key == "all" else ("L2b" if key == 12 else f"L{key}")
        share = f"{old} ({100 * old / n:.0f} %) | {new} ({100 * new / n:.0f} %)"
        print(f"| {name} | {n} | {share} | {gained} / {lost} | {p:.2g} |")


if __name__ == "__main__":
    if sys.argv[1:2] == ["run"] and len(sys.argv) == 5:
        run(json.loads(sys.argv[2]), [int(x) for x in sys.argv[3].split(",")], sys.argv[4])
    elif sys.argv[1:2] == ["table"] and "--against" in sys.argv[3:]:
        split = sys.argv.index("--against")
        table(sys.argv[2:split], sys.argv[split + 1 :])
    else:
        raise SystemExit(__doc__)
