"""`make demo`'s training, the config of before `train.processes` against today's, alternated.

Each round trains once with each config (the 2 x 1024 config of before, the same in 2 worker
processes as before `train.vector`, and today's) (the order rotated from round to round), timing only
`aaai train --curriculum --run RUN`; after all rounds every run is scored with
`aaai eval --seeds reserved --policy RUN` (untimed). Writes bench/demo_speed.csv (one row per
run) and bench/demo_speed.md (median and spread of the per-round ratio old / new, pass rates).
Resumable: runs already in the CSV are skipped.

    nice -n 10 .venv/bin/python bench/demo_speed.py --rounds 3
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import time
from pathlib import Path

from run_rows import AAAI, ROOT, load, read_rows, score, write_rows

# The shipped config before `train.processes` (git show 9f318fc^:configs/default.yaml): 2 x 1024;
# and the same with its 2 worker processes, as `make demo` trained before `train.vector`.
OLD = "train:\n  num_envs: 2\n  n_steps: 1024\n"
CONFIGS = {"old_2x1024": OLD, "now_default": None, "old_2x1024_processes": OLD + "  vector: async\n"}
NOW = "now_default"
FIELDS = ["round", "config", "seconds", "load_before", "load_after", "pass_rate", "passed", "episodes"]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--work", default=str(ROOT / "runs" / "demo_speed"))
    parser.add_argument("--out", default=str(ROOT / "bench"))
    args = parser.parse_args()
    work, out = Path(args.work), Path(args.out)
    work.mkdir(parents=True, exist_ok=True)
    csv_path = out / "demo_speed.csv"
    rows = read_rows(csv_path)
    done = {(r["round"], r["config"]) for r in rows}
    names = list(CONFIGS)
    for round_ in range(args.rounds):
        order = names[round_ % len(names) :] + names[: round_ % len(names)]
        for name in order:
            if (str(round_), name) in done:
                continue
            run = work / f"{name}-r{round_}"
            shutil.rmtree(run, ignore_errors=True)
            command = [AAAI, "train", "--curriculum", "--run", str(run)]
            if CONFIGS[name] is not None:
                config = work / f"{name}.yaml"
                config.write_text(CONFIGS[name])
                command += ["--config", str(config)]
            before = load()
            start = time.perf_counter()
            subprocess.run(command, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
            seconds = time.perf_counter() - start
            row = {"round": round_, "config": name, "seconds": round(seconds, 1), "load_before": before}
            row["load_after"] = load()
            rows.append(row)
            write_rows(csv_path, rows, FIELDS)
            print(row, flush=True)
    for row in rows:
        if row.get("pass_rate") in (None, ""):
            passed, episodes, _ = score(work / f"{row['config']}-r{row['round']}")
            row.update(passed=passed, episodes=episodes, pass_rate=round(passed / episodes, 3))
            write_rows(csv_path, rows, FIELDS)
            print(row, flush=True)
    report(rows, out / "demo_speed.md")


def report(rows: list[dict], path: Path) -> None:
    by = {(int(r["round"]), r["config"]): r for r in rows}
    lines = [
        "# `make demo` training: the configs of before `train.processes` and `train.vector` against today's",
        "",
        "`bench/demo_speed.py`: `aaai train --curriculum --run RUN` timed, the two configs alternated",
        "(order rotated each round), then `aaai eval --seeds reserved --policy RUN` on each run.",
        "",
        "| round | config | training s | load before -> after | passed or better (reserved) |",
        "|---|---|---:|---|---:|",
    ]
    for r in sorted(rows, key=lambda r: (int(r["round"]), r["config"])):
        rate = f"{float(r['pass_rate']):.0%} ({r['passed']}/{r['episodes']})" if r.get("pass_rate") else "-"
        lines.append(
            f"| {r['round']} | {r['config']} | {r['seconds']} | {r['load_before']} -> {r['load_after']} | {rate} |"
        )
    lines.append("")
    for old in (name for name in CONFIGS if name != NOW):
        rounds = sorted(r for r, n in by if n == old and (r, NOW) in by)
        ratios = [float(by[(r, old)]["seconds"]) / float(by[(r, NOW)]["seconds"]) for r in rounds]
        if ratios:
            lines.append(
                f"- Speed-up {old} / {NOW} (per round): median {statistics.median(ratios):.2f}"
                f" ({min(ratios):.2f}..{max(ratios):.2f}) over {len(ratios)} rounds."
            )
    for name in CONFIGS:
        rates = [float(r["pass_rate"]) for r in rows if r["config"] == name and r.get("pass_rate")]
        if rates:
            lines.append(
                f"- {name}: pass rate median {statistics.median(rates):.0%} ({min(rates):.0%}..{max(rates):.0%})"
            )
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
