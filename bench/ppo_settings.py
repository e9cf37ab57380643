"""PPO settings compared as `make demo` runs them: training wall time and the reserved-seed pass rate.

Each setting (a config override of the shipped config) trains `aaai train --curriculum --run RUN`
once per training seed (`train.seed`), the settings alternated within each seed (the order
rotated from seed to seed); then every run is scored with `aaai eval --seeds reserved --policy RUN`
(untimed). Writes bench/ppo_settings.csv (one row per run) and bench/ppo_settings.md (per setting:
median wall time and the per-seed ratio against the shipped setting, pass rates). Resumable: runs
already in the CSV are skipped.

    nice -n 10 .venv/bin/python bench/ppo_settings.py --seeds 0,1,2,3
    nice -n 10 .venv/bin/python bench/ppo_settings.py --seeds 4,5,6,7 --settings shipped,32x64_w64_e6
    .venv/bin/python bench/ppo_settings.py --ratios --seeds none

With ``--ratios`` it also measures each setting's throughput as `aaai bench --config` does: the
training row (``aaai.tools.bench.training_rates``: PPO against the environment alone, the same
vector env, alternated rounds), written to bench/ppo_settings_ratio.csv (resumable) and reported
as the setting's "PPO / env alone" (median and spread over rounds).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import time
from pathlib import Path

from run_rows import AAAI, ROOT, load, read_rows, score, write_rows

SHIPPED = "shipped"
SETTINGS = {
    SHIPPED: {},
    "16x128_e4_b512": {"num_envs": 16, "n_steps": 128, "n_epochs": 4, "batch_size": 512},
    "8x256_e4_b512": {"n_epochs": 4, "batch_size": 512},
    "16x128": {"num_envs": 16, "n_steps": 128},
    # the first setting given the shipped setting's wall time: 1.41 x its steps
    "16x128_e4_b512_140k": {"num_envs": 16, "n_steps": 128, "n_epochs": 4, "batch_size": 512, "total_steps": 140000},
    # more environments per forward pass, fewer passes over each rollout (batch 256 kept)
    "32x64_e5": {"num_envs": 32, "n_steps": 64, "n_epochs": 5},
    "16x128_w64_e5": {"num_envs": 16, "n_steps": 128, "net_width": 64, "n_epochs": 5},
    "16x128_w64_e6": {"num_envs": 16, "n_steps": 128, "net_width": 64, "n_epochs": 6},
    "32x64_w64_e6": {"num_envs": 32, "n_steps": 64, "net_width": 64, "n_epochs": 6},
    "32x64_w64_e8": {"num_envs": 32, "n_steps": 64, "net_width": 64, "n_epochs": 8},
    "32x64_w64": {"num_envs": 32, "n_steps": 64, "net_width": 64},
    # the 32 x 64 setting given about the shipped setting's wall time: 1.5 x its steps
    "32x64_w64_e6_150k": {"num_envs": 32, "n_steps": 64, "net_width": 64, "n_epochs": 6, "total_steps": 150000},
    # and twice the shipped setting's steps: does a >= 0.6 setting match its pass rate, and at what wall time?
    "32x64_w64_e6_200k": {"num_envs": 32, "n_steps": 64, "net_width": 64, "n_epochs": 6, "total_steps": 200000},
}
RATIO_FIELDS = ["setting", "ratio_median", "ratio_min", "ratio_max", "rounds", "load_before", "load_after"]
FIELDS = ["seed", "setting", "seconds", "load_before", "load_after", "passed", "episodes", "pass_rate", "mean_return"]


def config_text(setting: dict, seed: int) -> str:
    lines = ["train:", f"  seed: {seed}"] + [f"  {key}: {value}" for key, value in setting.items()]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", default="0,1,2,3")
    parser.add_argument("--settings", default=",".join(SETTINGS), help="names of SETTINGS to run, comma-separated")
    parser.add_argument("--ratios", action="store_true", help="also measure each setting's PPO / env alone")
    parser.add_argument("--rounds", type=int, default=3, help="alternated rounds of the --ratios measurement")
    parser.add_argument("--work", default=str(ROOT / "runs" / "ppo_settings"))
    parser.add_argument("--out", default=str(ROOT / "bench"))
    args = parser.parse_args()
    work, out = Path(args.work), Path(args.out)
    work.mkdir(parents=True, exist_ok=True)
    csv_path = out / "ppo_settings.csv"
    rows = read_rows(csv_path)
    done = {(r["seed"], r["setting"]) for r in rows}
    names = [name for name in SETTINGS if name in args.settings.split(",")]
    seeds = [] if args.seeds == "none" else [int(s) for s in args.seeds.split(",")]
    for index, seed in enumerate(seeds):
        order = names[index % len(names) :] + names[: index % len(names)]
        for name in order:
            if (str(seed), name) in done:
                continue
            run = work / f"{name}-s{seed}"
            shutil.rmtree(run, ignore_errors=True)
            config = work / f"{name}-s{seed}.yaml"
            config.write_text(config_text(SETTINGS[name], seed))
            command = [AAAI, "train", "--curriculum", "--run", str(run), "--config", str(config)]
            before = load()
            start = time.perf_counter()
            subprocess.run(command, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
            row = {"seed": seed, "setting": name, "seconds": round(time.perf_counter() - start, 1)}
            row.update(load_before=before, load_after=load())
            rows.append(row)
            write_rows(csv_path, rows, FIELDS)
            print(row, flush=True)
    for row in rows:
        if row.get("pass_rate") in (None, ""):
            passed, episodes, mean_return = score(work / f"{row['setting']}-s{row['seed']}")
            row.update(passed=passed, episodes=episodes, pass_rate=round(passed / episodes, 3))
            row["mean_return"] = round(mean_return, 3)
            write_rows(csv_path, rows, FIELDS)
            print(row, flush=True)
    ratio_path = out / "ppo_settings_ratio.csv"
    ratios = read_rows(ratio_path)
    if args.ratios:
        measure_ratios(names, ratios, ratio_path, args.rounds)
    report(rows, ratios, out / "ppo_settings.md")


def measure_ratios(names: list[str], ratios: list[dict], path: Path, rounds: int) -> None:
    """PPO / env alone of each setting not yet in ``path``: the training row of `aaai bench --config`."""
    from aaai.tools.bench import training_rates

    done = {r["setting"] for r in ratios}
    for name in names:
        if name in done:
            continue
        row = {"setting": name, "rounds": rounds, "load_before": load()}
        measured = training_rates(4096, rounds, {"train": SETTINGS[name]})
        ratio = measured["ratios"]["PPO / env alone"]
        row.update(ratio_median=round(ratio["median"], 3), ratio_min=round(ratio["min"], 3))
        row.update(ratio_max=round(ratio["max"], 3), load_after=load())
        ratios.append(row)
        write_rows(path, ratios, RATIO_FIELDS)
        print(row, flush=True)


def report(rows: list[dict], throughput: list[dict], path: Path) -> None:
    ratio_of = {r["setting"]: r for r in throughput}
    by = {(str(r["seed"]), r["setting"]): r for r in rows}  # seeds read back from the CSV are text
    lines = [
        "# PPO settings as `make demo` trains them",
        "",
        "`bench/ppo_settings.py`: `aaai train --curriculum` (100,000 steps unless set, L0 d0-2) timed per training",
        "seed, the settings alternated, then `aaai eval --seeds reserved` (30 episodes) on each run. PPO / env",
        "alone: `--ratios`, the training row of `aaai bench --config` (3 alternated rounds of 4,096 steps), median",
        "(min..max).",
        "",
        "| seed | setting | training s | load before -> after | passed or better | mean return |",
        "|---|---|---:|---|---:|---:|",
    ]
    for r in sorted(rows, key=lambda r: (int(r["seed"]), r["setting"])):
        rate = f"{float(r['pass_rate']):.0%} ({r['passed']}/{r['episodes']})" if r.get("pass_rate") else "-"
        lines.append(
            f"| {r['seed']} | {r['setting']} | {r['seconds']} | {r['load_before']} -> {r['load_after']} | {rate} "
            f"| {r.get('mean_return') or '-'} |"
        )
    lines.append("")
    for name, setting in SETTINGS.items():
        own = [r for r in rows if r["setting"] == name]
        if not own:
            continue
        seconds = [float(r["seconds"]) for r in own]
        ratios = [
            float(by[(str(r["seed"]), SHIPPED)]["seconds"]) / float(r["seconds"])
            for r in own
            if (str(r["seed"]), SHIPPED) in by
        ]
        rates = [float(r["pass_rate"]) for r in own if r.get("pass_rate")]
        text = f"- {name} {setting or '(configs/default.yaml)'}: training median {statistics.median(seconds):.0f} s"
        if name in ratio_of:
            r = ratio_of[name]
            low, high = float(r["ratio_min"]), float(r["ratio_max"])
            text += f", PPO / env alone {float(r['ratio_median']):.2f} ({low:.2f}..{high:.2f})"
        if ratios and name != SHIPPED:
            text += f", shipped / this per seed {statistics.median(ratios):.2f} ({min(ratios):.2f}..{max(ratios):.2f})"
        if rates:
            text += f"; pass rate mean {statistics.mean(rates):.0%} (per seed {', '.join(f'{x:.0%}' for x in rates)})"
        lines.append(text)
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
