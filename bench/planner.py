"""The reference's planner (``aaai.levels.validate.path_costs``, Dijkstra in scipy's csgraph) against the
step-by-step Python search it replaced (the oracle of tests/test_planner.py), on the same grids.

Each round times both on each grid (the order alternated from round to round), ``--calls`` calls each,
and checks that they give the same array bit for bit. The grids are the reference's own (its walking
region and its float32 cell costs, its goals the cells near a piece of food): a level's (L9 at
difficulty 10, 140 x 140 cells) and an imported Animal-AI arena's (40 x 40 imported at scale 5: 200 x
200 units, 400 x 400 cells, a wall across most of it). With ``--episodes ARENA...`` the reference also
plays each arena file on ``--seeds`` with each planner (alternated), in this process, and the
episodes' seconds (the scoreboard's wall_seconds) are compared. Writes bench/planner.md.

    nice -n 10 .venv/bin/python bench/planner.py --rounds 7
    nice -n 10 .venv/bin/python bench/planner.py --rounds 5 --episodes BATTERY/01-01-01.yaml BATTERY/03-02-01.yaml
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from test_planner import oracle, plans, reference_map, wall_arena  # noqa: E402

from aaai.levels import generate, validate  # noqa: E402
from aaai.tools.rounds import alternate, per_round, spread_text, write_report  # noqa: E402

NEW = validate.path_costs
PLANNERS = {"python": oracle, "scipy": NEW}


def grids(folder: Path) -> dict[str, tuple]:
    """name: (region, goals, costs, shape) of each grid timed."""
    found = {}
    for name, spec in (("L9 d10 (level)", generate(9, 10, 1)), ("imported arena", wall_arena(folder))):
        walk, crowding = reference_map(spec)
        goals, cost = next(plans(spec, walk, crowding))
        found[name] = (walk, goals, cost)
    return found


def time_calls(planner, grid, calls: int) -> float:
    """Milliseconds per call."""
    started = time.perf_counter()
    for _ in range(calls):
        planner(*grid)
    return (time.perf_counter() - started) / calls * 1000


def bench_calls(rounds: int, calls: int, folder: Path) -> list[str]:
    """Each grid: both planners alternated over ``rounds`` (the same array from both, checked each
    round), ms per call and the ratio within each round."""
    lines = [
        "| grid | cells (in the region) | python ms/call | scipy ms/call | python / scipy |",
        "|---|---|---:|---:|---:|",
    ]
    for name, grid in grids(folder).items():
        assert np.array_equal(oracle(*grid), NEW(*grid)), f"{name}: the planners differ"
        times = alternate(
            {p: lambda planner=planner: time_calls(planner, grid, calls) for p, planner in PLANNERS.items()}, rounds
        )
        print(name, {p: [round(t, 2) for t in times[p]] for p in PLANNERS}, flush=True)
        walk = grid[0]
        lines.append(
            f"| {name} | {walk.shape[0]} x {walk.shape[1]} ({int(walk.sum()):,}) | {spread_text(times['python'])} "
            f"| {spread_text(times['scipy'])} | {spread_text(per_round(times['python'], times['scipy']))} |"
        )
    return lines


def bench_episodes(arenas: list[Path], seeds: list[int], rounds: int) -> list[str]:
    """The reference on each arena and seed with each planner, alternated; seconds per episode."""
    from aaai.config import load_config
    from aaai.scoring.evaluation import play_here
    from aaai.scoring.policies import resolve

    policy, config = resolve("reference"), load_config()
    seconds: dict[tuple[str, str], list[float]] = {}
    rows: dict[tuple[str, int, str], set] = {}
    for round_ in range(rounds):
        for arena in arenas:
            for seed in seeds:
                order = list(PLANNERS) if round_ % 2 == 0 else list(PLANNERS)[::-1]
                for planner in order:
                    validate.path_costs = PLANNERS[planner]
                    try:
                        (row,) = play_here(policy, config, [(0, 0, seed, arena)])
                    finally:
                        validate.path_costs = NEW
                    seconds.setdefault((arena.name, planner), []).append(row["wall_seconds"])
                    rows.setdefault((arena.name, seed, planner), set()).add(
                        tuple(v for k, v in row.items() if k != "wall_seconds")
                    )
                    print(round_, arena.name, seed, planner, row["steps"], row["wall_seconds"], flush=True)
    lines = [
        "| arena | episodes each | python s/episode | scipy s/episode | python / scipy | rows (but wall_seconds) |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for arena in arenas:
        old, new = seconds[arena.name, "python"], seconds[arena.name, "scipy"]
        kinds = [rows[arena.name, seed, p] for seed in seeds for p in PLANNERS]
        same = all(len(k) == 1 for k in kinds) and all(
            rows[arena.name, seed, "python"] == rows[arena.name, seed, "scipy"] for seed in seeds
        )
        lines.append(
            f"| {arena.name} | {len(old)} | {spread_text(old, 2)} | {spread_text(new, 2)} | "
            f"{statistics.median(old) / statistics.median(new):.2f} | {'identical' if same else 'differ'} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--calls", type=int, default=3, help="calls per planner, grid and round")
    parser.add_argument("--episodes", nargs="*", type=Path, default=[], help="arena files to play")
    parser.add_argument("--seeds", default="0", help="seeds of each arena file, e.g. 0,1")
    parser.add_argument("--episode-rounds", type=int, default=1)
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "planner.md")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        calls = bench_calls(args.rounds, args.calls, Path(folder))
    lines = [
        "# The reference's planner: scipy's Dijkstra against the Python search it replaced",
        "",
        f"`bench/planner.py --rounds {args.rounds} --calls {args.calls}`: per round and grid, {args.calls} calls",
        "of each planner (the order alternated by round), the same array from both every round, bit for bit.",
        "Median (min..max) over the rounds; the ratio is taken within each round.",
        "",
        *calls,
    ]
    if args.episodes:
        seeds = [int(s) for s in args.seeds.split(",")]
        lines += [
            "",
            f"The reference's episodes on arena files `aaai import-animalai` wrote from Animal-AI's competition "
            f"configs (seeds {args.seeds}, {args.episode_rounds} round(s), the planners alternated), seconds from "
            "the reset to the end (the scoreboard's wall_seconds); the rows but wall_seconds compared:",
            "",
            *bench_episodes(args.episodes, seeds, args.episode_rounds),
        ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
