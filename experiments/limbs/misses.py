"""The reference's misses on the imported battery, per body, each with how its episode ended (from
the scoreboard's columns: fell; the time ran out; or it ended early, on a death zone or a bad goal),
written to misses.md.   python experiments/limbs/misses.py"""

import csv
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent


def ending(row: dict) -> str:
    if row["fell"] == "True":
        return "fell"
    if int(row["steps"]) >= int(row["max_steps"]):
        return "time ran out" + (" (ate some food)" if int(row["food_eaten"]) else " (no food eaten)")
    return "ended early (a death zone or a bad goal)"


lines = ["# The reference's misses on the imported battery (seed 0 of each valid file)", ""]
for body in ("quadruped", "sphere"):
    with open(HERE / f"reference_{body}_arenas.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    missed = [r for r in rows if r["outcome"] == "failed"]
    lines += [f"## {body}: {len(missed)} of {len(rows)} missed", ""]
    lines += [f"- {reason}: {count}" for reason, count in Counter(map(ending, missed)).most_common()]
    lines += ["", "| arena | steps / limit | food eaten | wall hits | ending |", "|---|---:|---:|---:|---|"]
    lines += [
        f"| {r['arena']} | {r['steps']} / {r['max_steps']} | {r['food_eaten']} | {r['wall_hits']} | {ending(r)} |"
        for r in missed
    ]
    lines.append("")
(HERE / "misses.md").write_text("\n".join(lines))
