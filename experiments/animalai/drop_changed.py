"""Drop from battery scoreboards the rows of arena files that changed or left the battery since they
were scored, so that `aaai baselines --battery` scores those files again and leaves every other row
as it is.

    python experiments/animalai/drop_changed.py [--uses BEHAVIOUR] BATTERY baselines/battery/reference.csv ...

BATTERY is the new import (`aaai import-animalai`'s --out). For each scoreboard, a row is dropped when
its file is no longer at BATTERY's top level (no longer valid on every seed) or its SHA-256 differs
from the one the scoreboard's record (``<name>_scored_with.json``, ``arena_sha256``) holds, and with
``--uses BEHAVIOUR`` (a behaviour's type, e.g. bounce) when the file has an object with that behaviour:
for a change to how the behaviour moves, which the files' text does not show. The record loses those
files' hashes, and its ``arenas`` names BATTERY. Both files are rewritten
atomically. Prints what was dropped. `aaai baselines --battery BATTERY --battery-seeds N --only ...`
then scores the missing episodes (the files changed, and the files new to the battery).
"""

from __future__ import annotations

import csv
import io
import json
import sys
from pathlib import Path

from aaai.files import write_atomic
from aaai.safe_yaml import load_mapping
from aaai.scoring.provenance import ARENA_HASHES, arena_hashes, read_record, record_path
from aaai.train.limbs import read_rows


def uses(path: Path, behaviour: str) -> bool:
    """Has the arena file an object whose behaviour is of type ``behaviour``?"""
    data = load_mapping(path, "arena file")
    return any(((obj or {}).get("behaviour") or {}).get("type") == behaviour for obj in data.get("objects") or [])


def drop(battery: Path, board: Path, behaviour: str | None = None) -> list[str]:
    record = read_record(board)
    hashes: dict[str, str] = record[ARENA_HASHES]
    now = arena_hashes(battery.glob("*.yaml"))
    moved = {path.name for path in battery.glob("*.yaml") if behaviour and uses(path, behaviour)}
    gone = sorted(name for name, sha in hashes.items() if now.get(name) != sha or name in moved)
    rows = read_rows(board)
    kept = [row for row in rows if row["arena"] not in gone]
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(rows[0]))  # as aaai eval writes them: \r\n
    writer.writeheader()
    writer.writerows(kept)
    write_atomic(board, text.getvalue())
    record[ARENA_HASHES] = {name: sha for name, sha in hashes.items() if name not in gone}
    record["arenas"] = str(battery.resolve())
    write_atomic(record_path(board), json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"{board}: {len(rows) - len(kept)} rows of {len(gone)} files dropped: {', '.join(gone)}")
    return gone


def main(argv: list[str]) -> int:
    behaviour = None
    if argv[:1] == ["--uses"] and len(argv) > 1:
        behaviour, argv = argv[1], argv[2:]
    if len(argv) < 2:
        print(__doc__)
        return 2
    for board in argv[1:]:
        drop(Path(argv[0]), Path(board), behaviour)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
