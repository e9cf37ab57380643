"""The clearance map (``aaai.levels.validate.clearance_map``): OpenCV's distance transform, which it used,
against the exact one (scipy's, ``validate.distances``), which it uses now.

1. Variants: OpenCV's ``distanceTransform(DIST_L2, DIST_MASK_PRECISE)`` written into an output buffer at
   each of 16 float32 offsets past a 64-byte boundary, on a level's grid and an imported Animal-AI arena's;
   how many different arrays, and in how many cells each differs from the exact distance; the same with
   OpenCV's use of Intel IPP switched off; the exact map over 20 memory layouts of the grid.
2. Where it starts: OpenCV hands a grid of fewer than 2**14 cells to IPP (random grids 127 x 127 and 128 x 128);
   and IPP's code for other CPUs (``OPENCV_IPP=avx2`` or ``sse42``, set before OpenCV loads) gives other arrays.
3. Time per call, OpenCV against the exact, alternated by round.
4. With ``--episodes``: the reference's steps on episodes whose route moved, with OpenCV's map written at
   each alignment and with the exact map, and how often an episode computes a clearance map.

    nice -n 10 .venv/bin/python bench/clearance.py --rounds 7 --episodes
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from test_clearance import layouts  # noqa: E402
from test_planner import wall_arena  # noqa: E402

from aaai.levels import generate, validate  # noqa: E402
from aaai.levels.validate import GRID  # noqa: E402
from aaai.tools.rounds import alternate, per_round, spread_text, write_report  # noqa: E402

EXACT = validate.clearance_map
EPISODES = [(3, 0, 1372987030), (10, 10, 1525883966), (3, 9, 1715746910)]


def opencv(free: np.ndarray, offset: int | None = None) -> np.ndarray:
    """OpenCV's distances (cells), written ``offset`` float32s past a 64-byte boundary (None: where OpenCV puts it)."""
    image = (free != 0).astype(np.uint8)
    if offset is None:
        return cv2.distanceTransform(image, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    buffer = np.zeros(image.size + 32, np.float32)
    start = (-buffer.ctypes.data % 64) // 4 + offset
    out = buffer[start : start + image.size].reshape(image.shape)
    cv2.distanceTransform(image, cv2.DIST_L2, cv2.DIST_MASK_PRECISE, dst=out)
    return out


def opencv_clearance(offset: int | None = None):
    """clearance_map as it was, its OpenCV output at ``offset``."""

    def clearance_map(spec, grid=None):
        grid = validate.blocked_grid(spec) if grid is None else grid
        return opencv(np.pad(grid, 1, constant_values=1) == 0, offset)[1:-1, 1:-1] * GRID

    return clearance_map


def variants(free: np.ndarray) -> tuple[int, list[int], int]:
    """OpenCV's different arrays over 16 output offsets, each one's cells that differ from the exact
    distance, and the cells that differ between any two of them."""
    found: dict[bytes, np.ndarray] = {}
    for offset in range(16):
        out = opencv(free, offset)
        found.setdefault(out.tobytes(), out.copy())
    exact = validate.distances(free)
    arrays = list(found.values())
    moving = np.any([a != arrays[0] for a in arrays], axis=0)
    return len(arrays), [int((a != exact).sum()) for a in arrays], int(moving.sum())


def grids(folder: Path) -> dict[str, tuple]:
    """name: (spec, blocked grid)."""
    found = {}
    for level, difficulty, seed in EPISODES[:2]:
        spec = generate(level, difficulty, seed)
        found[f"L{level} d{difficulty} seed {seed}"] = spec, validate.blocked_grid(spec)
    arena = wall_arena(folder)
    found["imported arena (wall)"] = arena, validate.blocked_grid(arena)
    return found


def section_variants(cases: dict[str, tuple]) -> list[str]:
    lines = [
        "| grid (padded) | cells | OpenCV: arrays over 16 offsets | cells != exact, each | cells that move "
        "| without IPP: arrays, cells != exact | exact map: arrays over 20 layouts |",
        "|---|---:|---:|---|---:|---|---:|",
    ]
    for name, (spec, grid) in cases.items():
        free = np.pad(grid, 1, constant_values=1) == 0
        count, wrong, moving = variants(free)
        cv2.ipp.setUseIPP(False)
        try:
            plain_count, plain_wrong, _ = variants(free)
        finally:
            cv2.ipp.setUseIPP(True)
        exact = {EXACT(spec, g).tobytes() for g in layouts(grid)}
        lines.append(
            f"| {name} ({free.shape[0]} x {free.shape[1]}) | {free.size:,} | {count} | {', '.join(map(str, wrong))} "
            f"| {moving} | {plain_count}, {', '.join(map(str, plain_wrong))} | {len(exact)} |"
        )
    rng = np.random.default_rng(0)
    for side in (127, 128):
        free = rng.random((side, side)) > 0.02
        count, wrong, moving = variants(free)
        lines.append(
            f"| random, 2 % blocked ({side} x {side}) | {side * side:,} | {count} | {', '.join(map(str, wrong))} "
            f"| {moving} | | |"
        )
    return lines


CPU_PATH = """
import sys, hashlib
sys.path.insert(0, {bench!r})
import cv2, numpy as np
from clearance import opencv
from aaai.levels import generate, validate
free = np.pad(validate.blocked_grid(generate(3, 0, 1372987030)), 1, constant_values=1) == 0
outs = [opencv(free, offset) for offset in range(8)]
print(cv2.ipp.getIppVersion() if cv2.ipp.useIPP() else "no IPP", "|", len({{o.tobytes() for o in outs}}), "|",
      int((outs[0] != validate.distances(free)).sum()), "|", hashlib.sha256(outs[0].tobytes()).hexdigest()[:12])
"""


def section_cpus() -> list[str]:
    """L3 d0 seed 1372987030's grid with IPP's code for each CPU, in a subprocess each."""
    lines = [
        "| `OPENCV_IPP` | IPP's code | arrays over 8 offsets | cells != exact at offset 0 | SHA-256 at offset 0 |",
        "|---|---|---:|---:|---|",
    ]
    for value in ("", "avx2", "sse42", "disabled"):
        code = CPU_PATH.format(bench=str(ROOT / "bench"))
        env = {**os.environ, "OPENCV_IPP": value}
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        lines.append(f"| {value or '(unset)'} | {out.stdout.strip().splitlines()[-1]} |")
    exact = hashlib.sha256(
        validate.distances(
            np.pad(validate.blocked_grid(generate(3, 0, 1372987030)), 1, constant_values=1) == 0
        ).tobytes()
    ).hexdigest()[:12]
    lines.append(f"| exact (`validate.distances`), any | | 1 | 0 | {exact} |")
    return lines


def section_time(cases: dict[str, tuple], rounds: int, calls: int) -> list[str]:
    """Each grid: OpenCV's map and the exact one alternated over ``rounds``, ms per call, and the ratio
    within each round."""
    makers = {"opencv": opencv_clearance(), "exact": EXACT}

    def timed(maker, spec, grid) -> float:
        started = time.perf_counter()
        for _ in range(calls):
            maker(spec, grid)
        return (time.perf_counter() - started) / calls * 1000

    lines = ["| grid | OpenCV ms/call | exact ms/call | exact / OpenCV |", "|---|---:|---:|---:|"]
    for name, (spec, grid) in cases.items():
        times = alternate({m: lambda maker=maker: timed(maker, spec, grid) for m, maker in makers.items()}, rounds)
        old, new = times["opencv"], times["exact"]
        lines.append(
            f"| {name} | {spread_text(old, 2)} | {spread_text(new, 2)} | {spread_text(per_round(new, old), 1)} |"
        )
    return lines


def section_episodes() -> list[str]:
    from aaai.config import load_config
    from aaai.scoring.evaluation import play_here
    from aaai.scoring.policies import resolve

    policy, config = resolve("reference"), load_config()
    calls = [0]

    def counted(maker):
        def clearance_map(spec, grid=None):
            calls[0] += 1
            return maker(spec, grid)

        return clearance_map

    offsets: list[int | str] = [*range(8), "exact"]
    lines = [
        "| episode | " + " | ".join(f"OpenCV at {o}" for o in offsets[:-1]) + " | exact | maps per episode |",
        "|---|" + "---:|" * (len(offsets) + 1),
    ]
    for level, difficulty, seed in EPISODES:
        steps = []
        for offset in offsets:
            validate.clearance_map = counted(EXACT if offset == "exact" else opencv_clearance(int(offset)))
            calls[0] = 0
            try:
                (row,) = play_here(policy, config, [(level, difficulty, seed)])
            finally:
                validate.clearance_map = EXACT
            steps.append(row["steps"])
            print(level, difficulty, seed, offset, row["steps"], calls[0], flush=True)
        lines.append(f"| L{level} d{difficulty} seed {seed} | " + " | ".join(map(str, steps)) + f" | {calls[0]} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--calls", type=int, default=20, help="calls per map, grid and round")
    parser.add_argument("--episodes", action="store_true", help="play the reference's episodes (about a minute)")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "clearance.md")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        cases = grids(Path(folder))
    lines = [
        "# The clearance map: OpenCV's distance transform against the exact one",
        "",
        f"`bench/clearance.py --rounds {args.rounds} --calls {args.calls}{' --episodes' if args.episodes else ''}`"
        f" (OpenCV {cv2.__version__}, {cv2.ipp.getIppVersion()}).",
        "",
        "OpenCV's `distanceTransform(DIST_L2, DIST_MASK_PRECISE)` into an output buffer at each of 16 float32",
        "offsets past a 64-byte boundary; the cells of each different array that differ from the exact distance",
        "(float32); the cells that differ between them; the same without IPP (`cv2.ipp.setUseIPP(False)`);",
        "and the exact map (`validate.clearance_map` now) of the grid in 20 memory layouts (Fortran order,",
        "copies at 16 byte offsets, a strided view, bool):",
        "",
        *section_variants(cases),
        "",
        "L3 d0 seed 1372987030's grid with IPP's code for other CPUs (`OPENCV_IPP`, read when OpenCV loads):",
        "",
        *section_cpus(),
        "",
        f"Time per call of the clearance map (median (min..max) over {args.rounds} rounds of {args.calls} calls, "
        "the order alternated by round):",
        "",
        *section_time(cases, args.rounds, args.calls),
    ]
    if args.episodes:
        lines += [
            "",
            "The reference's steps with OpenCV's map written at each output offset (float32s past a 64-byte "
            "boundary; a fresh array from the heap lies at 0 or 4) and with the exact map; the clearance maps "
            "one episode computes (the level's checks when it is generated, the reference's map at the reset):",
            "",
            *section_episodes(),
        ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
