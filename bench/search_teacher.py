"""The searching reference (``--policy search``) against the all-knowing one, per level, in gait mode.

Scores three policies on the same reserved seeds with ``aaai eval`` (each a resumable scoreboard:
run the same command again to continue), then writes bench/search_teacher.md, the pass rate per
level with its 95 % Wilson interval, overall and at difficulties 0, 5 and 10
(``aaai.tools.baselines.table_markdown``):

- ``reference``: the all-knowing reference;
- ``search_default``: the searching reference on the default senses (17 rays over 90 degrees, 15 long);
- ``search_strict_default``: the strict one (``--policy search_strict``: the walls too known only as
  the rays show them) on the default senses;
- ``search_thorough_default``: the thorough one (``--policy search_thorough``: it searches on for food it
  has not seen before eating a green) on the default senses;
- ``search_student``: the searching reference on configs/student.yaml's senses (33 rays all round, 50
  long, two fans).

    nice -n 10 .venv/bin/python bench/search_teacher.py                        # all 1,430 episodes each
    nice -n 10 .venv/bin/python bench/search_teacher.py -k 2 --difficulty 0,5,10 --tag small
    .venv/bin/python bench/search_teacher.py --table-only                      # the table from the CSVs

The scoreboards are bench/search_teacher{_TAG}_{NAME}.csv, one per name above.
"""

from __future__ import annotations

import argparse
import subprocess
import sys

from run_rows import AAAI, ROOT

sys.path.insert(0, str(ROOT))

from aaai.scoring.scoreboard import scored_episodes  # noqa: E402
from aaai.tools.baselines import table_markdown  # noqa: E402

POLICIES = {  # name: (policy, extra eval arguments)
    "reference": ("reference", []),
    "search_default": ("search", []),
    "search_strict_default": ("search_strict", []),
    "search_thorough_default": ("search_thorough", []),
    "search_student": ("search", ["--config", "configs/student.yaml"]),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-k", type=int, default=10, help="reserved seeds per cell (10: all 1,430)")
    parser.add_argument("--difficulty", default="0-10")
    parser.add_argument("--levels", default="all")
    parser.add_argument("--tag", default="", help="names the scoreboards and the table: search_teacher_TAG")
    parser.add_argument("--table-only", action="store_true", help="write the table from the scoreboards there are")
    args = parser.parse_args()
    stem = "search_teacher" + (f"_{args.tag}" if args.tag else "")
    boards = {}
    for name, (policy, extra) in POLICIES.items():
        out = ROOT / "bench" / f"{stem}_{name}.csv"
        if not args.table_only:
            command = [AAAI, "eval", "--seeds", "reserved", "-k", str(args.k), "--levels", args.levels]
            command += ["--difficulty", args.difficulty, "--policy", policy, "--action-mode", "gait"]
            command += [*extra, "--out", str(out)]
            subprocess.run(command, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
        if out.exists():
            boards[name] = scored_episodes(out)
    table = ROOT / "bench" / f"{stem}.md"
    text = (
        f"# The searching reference against the all-knowing one (gait mode, {args.k} reserved seeds per cell)\n\n"
        "Pass rate (passed or succeeded) per level with its 95 % Wilson interval: all difficulties scored, "
        "then d0 / d5 / d10. Made by bench/search_teacher.py from its scoreboards.\n\n" + table_markdown(boards)
    )
    partial = table.with_suffix(".md.partial")
    partial.write_text(text)
    partial.replace(table)
    print(text)


if __name__ == "__main__":
    main()
