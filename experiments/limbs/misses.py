"""The reference's misses on the imported battery, per body, each with how its episode ended (from
the scoreboard's columns: fell; the time ran out; or it ended early, on a death zone or a bad goal)
and, for the families replayed one by one (CAUSES), why, written to misses.md.
python experiments/limbs/misses.py"""

import csv
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
TIME = "the way is long for a body that walks about 2.7 units a second (Animal-AI's agent is about 3 times as fast)"
BOUNCING = (
    "bouncing pieces (speed 3, about the body's walking speed) and bouncing bad food: the reference aims "
    "where a piece is, not where it will be, and bad food that moves is not dodged (its start is blocked)"
)
CRAMPED = "wall hits on the last steps to a piece in a passage about as wide as the body, below the pass mark"
# why, by family (the file's name without its variant), as replayed one episode at a time (seed 0)
CAUSES = {
    "quadruped": {
        "01-22": f"41 pieces for a pass mark of 193: it eats 33 to 38 of them in the 640 s; {TIME}",
        "01-26": BOUNCING,
        "01-29": BOUNCING,
        "01-30": BOUNCING,
        "06-14": BOUNCING,
        "03-07": CRAMPED,
        "05-03": CRAMPED,
        "05-26": CRAMPED,
        "04-20": "a foot over a death zone on the last steps, at the end of a corridor 12 wide between death zones",
        "05-04": f"the only way in is about 380 units long for 160 s: {TIME}",
        "05-06": f"the only way in is long, through passages about as wide as the body: {TIME}",
        "07-13": "the pass mark (18) is above all the arena pays (one green worth 10): no body passes it",
        "08-01": "two big pieces (size 10) in rooms behind gaps 11 wide, walked slowly: the 160 s are just "
        f"enough (7,000 to 7,900 of 8,000 steps when it passes); {TIME}",
        "08-02": "as 08-01",
        "08-03": "as 08-01, the pieces in the two side rooms, farther apart",
    },
    "sphere": {
        "01-26": "bouncing bad food runs into it in the first seconds",
        "07-13": "the pass mark (18) is above all the arena pays (one green worth 10): no body passes it",
    },
}


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
    lines += ["", "| arena | steps / limit | food eaten | wall hits | ending | cause |", "|---|---:|---:|---:|---|---|"]
    lines += [
        f"| {r['arena']} | {r['steps']} / {r['max_steps']} | {r['food_eaten']} | {r['wall_hits']} | {ending(r)} "
        f"| {CAUSES[body].get(r['arena'][:5], '-')} |"
        for r in missed
    ]
    lines.append("")
(HERE / "misses.md").write_text("\n".join(lines))
