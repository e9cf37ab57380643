"""The soak: random actions over every level at random difficulties (0-10), camera (32 px) and rays
on, episodes of 500 steps, a reset at each end. It records, every chunk of steps, the process's
RSS and the PyBullet connections open, as one JSON line appended to the output file.

    nice -n 10 python bench/soak.py --steps 1000000 --out soak.jsonl

Resumable: run the same command again and it continues after the last chunk recorded (in a new
process, so the RSS of the resumed part starts afresh; each line says which process wrote it).
Chunk ``i`` draws its levels, difficulties, seeds and actions from seed ``(seed, i)``, so a chunk
is the same whichever process runs it.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np


def rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def pybullet_connections() -> int:
    import pybullet

    return sum(bool(pybullet.isConnected(i)) for i in range(64))


def _done_chunks(out: Path) -> list[dict]:
    if not out.exists():
        return []
    lines = []
    for line in out.read_text().splitlines():
        try:
            lines.append(json.loads(line))
        except json.JSONDecodeError:  # a line torn by a kill: that chunk runs again
            break
    return lines


def _append(out: Path, record: dict) -> None:
    text = out.read_text() if out.exists() else ""
    good = "".join(json.dumps(line) + "\n" for line in _done_chunks(out)) if text else ""
    if good != text:  # drop a torn tail before appending
        out.write_text(good)
    with open(out, "a") as handle:
        handle.write(json.dumps(record) + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def run(steps: int, out: Path | None = None, chunk: int = 25_000, seed: int = 0) -> list[dict]:
    """Run the soak up to ``steps`` steps in chunks; returns every chunk's record (those already
    in ``out`` included)."""
    from aaai.config import load_config
    from aaai.env import AnimalAIEnv
    from aaai.levels import level_ids

    records = _done_chunks(out) if out else []
    first = len(records)
    if first * chunk >= steps:
        return records
    env = AnimalAIEnv(
        config=load_config({"sensors": {"camera": True, "camera_resolution": 32}, "episode": {"max_steps": 500}})
    )
    levels = level_ids()
    started = time.time()
    for index in range(first, -(-steps // chunk)):
        rng = np.random.default_rng([seed, index])
        env.action_space.seed(int(rng.integers(2**31)))
        levels_seen, episodes = set(), 0

        def reset():
            level = int(rng.choice(levels))
            levels_seen.add(level)
            env.reset(seed=int(rng.integers(10**6)), options={"level": level, "difficulty": int(rng.integers(0, 11))})

        reset()
        for _ in range(min(chunk, steps - index * chunk)):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                episodes += 1
                reset()
        record = {
            "chunk": index,
            "steps_total": min(steps, (index + 1) * chunk),
            "episodes": episodes,
            "levels": sorted(levels_seen),
            "rss_mb": round(rss_mb(), 2),
            "connections": pybullet_connections(),
            "pid": os.getpid(),
            "seconds_in_process": round(time.time() - started, 1),
        }
        records.append(record)
        if out:
            _append(out, record)
    env.close()
    records[-1]["connections_after_close"] = pybullet_connections()
    return records


def summary(records: list[dict]) -> dict:
    """RSS growth within the longest single-process stretch (after its first chunk, the warm-up),
    the connections seen, and the levels covered."""
    by_pid: dict[int, list[dict]] = {}
    for record in records:
        by_pid.setdefault(record["pid"], []).append(record)
    longest = max(by_pid.values(), key=len)
    return {
        "steps": records[-1]["steps_total"],
        "episodes": sum(r["episodes"] for r in records),
        "processes": len(by_pid),
        "levels": sorted({level for r in records for level in r["levels"]}),
        "rss_after_warm_up_mb": longest[0]["rss_mb"],
        "rss_end_mb": longest[-1]["rss_mb"],
        "rss_max_mb": max(r["rss_mb"] for r in longest),
        "steps_in_longest_process": longest[-1]["steps_total"] - longest[0]["steps_total"],
        "connections": sorted({r["connections"] for r in records}),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000)
    parser.add_argument("--chunk", type=int, default=25_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("soak.jsonl"))
    args = parser.parse_args()
    records = run(args.steps, args.out, args.chunk, args.seed)
    after_close = {"connections_after_close": records[-1]["connections_after_close"]} if records else {}
    print(json.dumps({**summary(records), **after_close}))


if __name__ == "__main__":
    main()
