"""The searching reference with its exploration constants changed, scored as ``aaai eval`` scores it.

    python experiments/students/teacher_variant.py '{"GAIN_WEIGHT": 120.0}' 5,0,2,4,8,9,12 A.csv
    python experiments/students/teacher_variant.py '{"GAIN_WEIGHT": 120.0}' 1,3,6,7,10,11 B.csv
    (cat A.csv; tail -n +2 B.csv) > VARIANT.csv
    aaai compare bench/search_teacher_search_default.csv VARIANT.csv

Sets the named constants of aaai.task.search (GAIN_WEIGHT, GAIN_SPAN, TURN_WEIGHT, ...) in this
process only, then runs aaai.scoring.evaluation.evaluate for ``--policy search`` in gait mode on the
default senses, in this process (so the constants hold), on the 110 reserved episodes of each given
level (10 seeds a difficulty: ``aaai eval --policy search --seeds reserved -k 10 --action-mode gait``).
The output is an ordinary scoreboard (flushed per episode, resumable); ``aaai compare`` sets it
against the unchanged teacher's.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(variant: dict, levels: list[int], out: str) -> None:
    import aaai.task.search as search
    from aaai.config import load_config
    from aaai.scoring.evaluation import evaluate
    from aaai.scoring.plan import cells_for

    for name, value in variant.items():
        if not hasattr(search, name):
            raise SystemExit(f"variant: got {name!r}; allowed: a constant of aaai.task.search")
        setattr(search, name, value)
    cells = cells_for(levels, list(range(11)), "reserved", 10)
    evaluate("search", cells, Path(out), load_config(None, action_mode="gait"))


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(json.loads(sys.argv[1]), [int(x) for x in sys.argv[2].split(",")], sys.argv[3])
