"""The arena-extremes group: arena files of in-range extremes (sizes, counts, heights, masses, angles,
times, colours, spans to draw from), run and shown."""

from __future__ import annotations

import functools
import subprocess

from .base import AAAI, attack
from .inputs import text

GROUP = "arena-extremes"


@functools.cache
def l11_heightfield(n: int) -> str:
    """L11's own arena file with its heightfield resampled to n x n heights."""
    import yaml

    done = subprocess.run([AAAI, "spec", "11", "--yaml"], capture_output=True, text=True, check=True)
    data = yaml.safe_load(done.stdout)
    rows = data["heightfield"]
    data["heightfield"] = [[rows[i * len(rows) // n][j * len(rows[0]) // n] for j in range(n)] for i in range(n)]
    return yaml.safe_dump(data, default_flow_style=None, width=10**6)


def arena_file(content):
    """``a.yaml`` holding ``content`` (text, or a function that makes it)."""
    return lambda w: text("a.yaml", content() if callable(content) else content)(w)


def food_at(x: str, extra: str = "") -> str:
    """The arena's line of one green food at (``x``, 5, 1.5), of size 3, with ``extra`` keys."""
    return "  - {kind: food_green, position: [" + x + ", 5, 1.5], size: [3, 3, 3]" + extra + "}\n"


def attacks():
    agent = "agent: {x: 0, y: -18, yaw: 1.5707963267948966}\n"
    food = food_at("0")

    def arena(body, objects=food, head=agent):
        return head + body + "objects:\n" + objects

    checker = "".join(  # 10,000 single holes, none near the start (tiles of 2.5 units)
        f"  - [{i}, {j}]\n" for i in range(0, 400, 4) for j in range(0, 400, 4) if not (150 < i < 250 and 150 < j < 250)
    )
    many = "".join(
        f"  - {{kind: food_green, position: [{-435 + (i % 30) * 30}, {-435 + (i // 30) * 30}, 0.25],"
        " size: [0.5, 0.5, 0.5]}\n"
        for i in range(900)
    )
    movers = "".join(
        f"  - {{kind: food_green, position: [{-40 + (i % 20) * 4}, {-10 + (i // 20) * 4}, 1], size: [1, 1, 1],"
        " behaviour: {type: random_walk, speed: 100.0}}\n"
        for i in range(200)
    )
    cases = {
        "huge-arena-checker-holes": arena("arena_size: [1000, 1000]\ntiles: [400, 400]\nholes:\n" + checker),
        "huge-arena-few-tiles": arena("arena_size: [1000, 1000]\ntiles: [1, 1]\n"),
        "tiny-arena": arena("arena_size: [0.001, 0.001]\n", objects=food, head="agent: {x: 0, y: 0}\n"),
        "heightfield-300x300": lambda: l11_heightfield(300),  # asks aaai spec: made when the attack is
        "heightfield-ragged": arena("heightfield:\n  - [0, 1, 2]\n  - [0]\n"),
        "heightfield-huge-values": arena("heightfield:\n  - [1.0e+300, -1.0e+300]\n  - [0, 1.0e+300]\n"),
        "900-small-foods": arena("arena_size: [1000, 1000]\n", objects=many),
        "200-fast-movers": arena("", objects=movers),
        "mass-1e30": arena(
            "", objects=food + "  - {kind: wall, position: [5, 0, 1], size: [1, 1, 1], mass: 1.0e+30}\n"
        ),
        "yaw-1e300": arena("", objects=food_at("0", ", yaw: 1.0e+300")),
        "wall-height-tiny": arena("wall_height: 1.0e-9\n"),
        "wall-height-huge": arena("wall_height: 1000\n"),
        "time-limit-200": arena("time_limit: 200\n"),
        "time-limit-0.2": arena("time_limit: 0.2\n"),
        "blackout-tiny": arena("blackout: {light: 1.0e-300, dark: 1.0e-300}\n"),
        "colours-extreme": arena("colours: {food_green: [1.0e+308, -1.0e+308, .nan, 2]}\n"),
        "object-size-1000": arena(
            "arena_size: [1000, 1000]\n",
            objects=food + "  - {kind: wall, position: [450, 0, 500], size: [1, 900, 1000]}\n",
        ),
        "agent-corner": arena("", head="agent: {x: 19.99, y: -19.99, yaw: 0}\n"),
        "agent-yaw-huge": arena("", head="agent: {x: 0, y: -18, yaw: 1.0e+300}\n"),
        "description-900kb": "description: " + "d" * 900_000 + "\n" + arena(""),
        "inner-seed-huge": arena("inner: {level: 0, name: x, difficulty: 0, seed: 18446744073709551617}\n"),
        "extras-deep": arena("extras: " + "{a: " * 19 + "1" + "}" * 19 + "\n"),
        "uniform-huge-range": arena("", objects=food_at("{uniform: [-1.0e+308, 1.0e+308]}")),
        "choice-10000": arena("", objects=food_at("{choice: [" + ",".join(["1"] * 10000) + "]}")),
        "max-food-reward-huge": arena("max_food_reward: 1.0e+308\n"),
        "integers-huge-range": arena("", objects=food_at("{integers: [-1.0e+30, 1.0e+30]}")),
    }
    run = [AAAI, "run", "--arena", "a.yaml", "--max-steps", "10", "--no-camera"]
    for name, content in cases.items():
        attack(f"arena-{name}-run", GROUP, run, arena_file(content), "any")
    show = [AAAI, "show", "--arena", "a.yaml", "-o", "o.png"]
    for name in ("huge-arena-checker-holes", "heightfield-300x300", "900-small-foods", "colours-extreme"):
        attack(f"arena-{name}-show", GROUP, show, arena_file(cases[name]), "any")
