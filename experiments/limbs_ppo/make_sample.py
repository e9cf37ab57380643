"""The battery sample PPO is scored on: the first file of each Animal-AI task family (competition
files XX-YY-NN share the family XX-YY) among the valid files of an import, leaving out starts on a
ledge (``extras.animalai.start_ledge``), which the sphere is refused on.

    python experiments/limbs_ppo/make_sample.py BATTERY SAMPLE   # BATTERY: `aaai import-animalai`'s --out

Copies the chosen files, unchanged, into SAMPLE (which must not exist yet) and prints how many.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import yaml


def sample(battery: Path) -> list[Path]:
    chosen: dict[str, Path] = {}
    for path in sorted(battery.glob("*.yaml")):
        extras = (yaml.safe_load(path.read_text()) or {}).get("extras") or {}
        if "start_ledge" in (extras.get("animalai") or {}):
            continue
        chosen.setdefault(path.name[:5], path)
    return list(chosen.values())


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    battery, out = Path(argv[0]), Path(argv[1])
    if out.exists():
        print(f"{out} exists: give a new folder", file=sys.stderr)
        return 2
    files = sample(battery)
    out.mkdir(parents=True)
    for path in files:
        shutil.copy2(path, out / path.name)
    print(f"{len(files)} files of {len(list(battery.glob('*.yaml')))} into {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
