"""Each level's formulas, pinned to the paper's text (shared reference: the paper's "The Test Bench"
section and the notes on the original environment, "Levels"), through the public surface: the spec
``aaai.levels.generate(level, difficulty, seed)`` returns, for several seeds, at the difficulty
bounds and a hair either side of each threshold.

Every expected number is written here as the paper (or the notes) gives it, never read back from a
level file, so a level whose formula drifts from the paper fails here. Where the code departs from
the paper on purpose, the test holds the paper's value and is marked xfail(strict=True) naming the
departure: if the code comes back to the paper, the strict xfail turns red and the mark must go.
"""

from __future__ import annotations

import functools
import math
from collections import deque

import pytest

from aaai.levels import generate
from aaai.spec.behaviours import Door, Sink, behaviour_class

SEEDS = range(12)
DIFFICULTIES = range(11)


@functools.cache
def spec(level, difficulty: int, seed: int):
    return generate(level, difficulty, seed)


def specs(level, difficulty: int, seeds=SEEDS):
    return [spec(level, difficulty, seed) for seed in seeds]


def of_kind(level_spec, *kinds):
    return [obj for obj in level_spec.objects if obj.kind in kinds]


def boundary(level_spec, obj) -> bool:
    """One of the four walls around the arena (their inner faces on its edges)."""
    half_x, half_y = level_spec.arena_size[0] / 2, level_spec.arena_size[1] / 2
    x, y = obj.position[:2]
    return obj.kind == "wall" and (
        math.isclose(abs(x), half_x + obj.size[0] / 2) or math.isclose(abs(y), half_y + obj.size[1] / 2)
    )


def inner_walls(level_spec, *kinds):
    return [obj for obj in of_kind(level_spec, *kinds) if not boundary(level_spec, obj)]


def agent_to(level_spec, obj) -> float:
    return math.hypot(obj.position[0] - level_spec.agent.x, obj.position[1] - level_spec.agent.y)


class FakeWorld:
    """What a moving part needs of the world to be advanced by hand: the time and a place()."""

    def __init__(self, time: float):
        self.time = time
        self.placed: tuple[float, float, float] = (math.nan, math.nan, math.nan)

    def place(self, body, position, yaw):
        self.placed = position


# ---------------------------------------------------------------- L0 Initial food contact


@pytest.mark.parametrize("seed", SEEDS)
def test_l0_at_difficulty_0_the_food_is_directly_in_front_of_the_agent(seed):
    level_spec = spec(0, 0, seed)
    (food,) = level_spec.foods
    # paper, Test Bench L0: "the food is placed directly in front of the agent";
    # notes, L0: "agent at the arena's south side facing north"
    assert level_spec.agent.yaw == pytest.approx(math.pi / 2)
    assert level_spec.agent.y < 0 and food.kind == "food_green"
    assert food.position[0] == pytest.approx(level_spec.agent.x) and food.position[1] > level_spec.agent.y


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l0_food_size_steps_down_with_difficulty(difficulty):
    # notes, L0: "size 4 (d<=4), 3 (d 5-7), 2 (d>=8)"; difficulties 4|5 and 7|8 are a hair either side
    expected = 4 if difficulty <= 4 else 3 if difficulty <= 7 else 2
    for level_spec in specs(0, difficulty):
        (food,) = level_spec.foods
        assert food.size[0] == expected
        assert level_spec.max_food_reward == expected  # paper, Rewards: green pays "their scale or size"


def test_l0_food_is_farther_and_more_off_centre_as_difficulty_grows():
    # paper, Test Bench L0: "the food is positioned farther away, becomes smaller, and varies in its
    # horizontal placement"; notes, L0: "sideways offset uniform in +-1.5d"
    distances = [spec(0, d, 0).foods[0].position[1] - spec(0, d, 0).agent.y for d in DIFFICULTIES]
    assert all(b > a for a, b in zip(distances, distances[1:])), distances
    for difficulty in (1, 10):
        offsets = [s.foods[0].position[0] - s.agent.x for s in specs(0, difficulty, range(40))]
        assert max(abs(o) for o in offsets) <= 1.5 * difficulty
        assert min(offsets) < -0.5 * 1.5 * difficulty and max(offsets) > 0.5 * 1.5 * difficulty  # both sides


# ---------------------------------------------------------------- L1 Basic food retrieval


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l1_pieces_one_green_the_rest_yellow_sizes_and_spacing(difficulty):
    for level_spec in specs(1, difficulty):
        foods = level_spec.foods
        # notes, L1: "round(0.4d+1) pieces (1..5): one green, the rest yellow, sizes 2..4; ... all at
        # least 10 apart"; paper, Test Bench L1: "ranging from 1 to 5 pieces"
        assert len(foods) == round(0.4 * difficulty + 1)
        assert [f.kind for f in foods].count("food_green") == 1
        assert all(f.kind in ("food_green", "food_yellow") for f in foods)
        assert all(2 <= f.size[0] <= 4 for f in foods)
        for i, a in enumerate(foods):
            for b in foods[i + 1 :]:
                assert math.dist(a.position[:2], b.position[:2]) >= 10
        # paper, Rewards: green pays its size, yellow half of it; all can be eaten
        best = sum(f.size[0] if f.kind == "food_green" else f.size[0] / 2 for f in foods)
        assert level_spec.max_food_reward == pytest.approx(best)


def test_l1_food_is_still_at_low_difficulty_and_moves_at_high():
    # paper, Test Bench L1: "At lower difficulty levels, the food is mostly stationary, but it begins
    # to move as the difficulty increases"; notes, L1: "each moves (random walk, speed 4) with probability 0.5"
    assert not any(f.behaviour for s in specs(1, 0, range(40)) for f in s.foods)
    moving = [f.behaviour for s in specs(1, 10, range(100)) for f in s.foods]
    share = sum(b is not None for b in moving) / len(moving)
    assert abs(share - 0.5) <= 3 * math.sqrt(0.25 / len(moving)), share  # 500 pieces at p = 0.5: 3 sigma
    assert all(b == {"type": "random_walk", "speed": 4} for b in moving if b is not None)


def test_l1_the_agent_heading_is_random():
    # notes, L1: "random agent heading"
    headings = [s.agent.yaw for s in specs(1, 5, range(40))]
    assert max(headings) - min(headings) > math.pi  # spread round the circle, not one heading


# ---------------------------------------------------------------- L2 Y-maze


@pytest.mark.parametrize("difficulty", [0, 5, 6, 10])  # 5 | 6: a hair either side of "above 5"
def test_l2_one_green_up_to_5_and_a_smaller_second_above(difficulty):
    arms = set()
    for level_spec in specs(2, difficulty):
        greens = sorted(of_kind(level_spec, "food_green"), key=lambda f: -f.size[0])
        # paper, Test Bench L2 Y-maze: "When the difficulty is below 5, there will be only one piece of
        # green food at one of the two paths. When the difficulty is above 5, there is an additional
        # smaller piece of green food in the other path"; notes, L2: "one green (size 3..4) ... d>5
        # also a smaller green (size 2)"
        assert len(greens) == (2 if difficulty > 5 else 1)
        assert 3 <= greens[0].size[0] <= 4
        if difficulty > 5:
            assert greens[1].size[0] == 2
            assert greens[0].position[0] * greens[1].position[0] < 0  # the other arm
        arms.add(greens[0].position[0] > 0)
        # only one green can be eaten (it ends the episode): the best arm's is the most to get
        assert level_spec.max_food_reward == greens[0].size[0]
    assert arms == {True, False}  # "a random arm"


# ---------------------------------------------------------------- L2b Delayed gratification


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l2b_pillar_sinks_to_the_floor_over_the_papers_time(difficulty):
    for level_spec in specs("L2b", difficulty, range(4)):
        (green,), (yellow,), (pillar,) = (of_kind(level_spec, k) for k in ("food_green", "food_yellow", "pillar"))
        agent = level_spec.agent
        # notes, L2 Delayed gratification: "a small green (size 2) 15 ahead; a larger yellow (size 3)
        # on a pillar 8 high that sinks to the floor over round(1.5d+5) s"; paper: "As the difficulty
        # increases, the time it takes for the pillar to descend also increases"
        assert green.size[0] == 2 and yellow.size[0] == 3
        assert agent.yaw == pytest.approx(math.pi / 2)
        assert (green.position[0], green.position[1]) == pytest.approx((agent.x, agent.y + 15))
        assert pillar.size[2] == 8 and yellow.position[2] - yellow.size[2] / 2 == pytest.approx(8)
        seconds = round(1.5 * difficulty + 5)
        for part in (pillar, yellow):
            assert part.behaviour["type"] == "sink" and part.behaviour["duration"] == seconds
        # a hair before the sink time the yellow is still above the floor; at it, it rests on the floor
        assert behaviour_class(yellow) is Sink
        mover = Sink(yellow)
        for at, resting in ((seconds - 1e-3, False), (seconds, True), (seconds + 1.0, True)):
            world = FakeWorld(at)
            mover.advance(world, 0, 0.02, None)
            bottom = world.placed[2] - yellow.size[2] / 2
            assert (bottom == pytest.approx(0, abs=1e-9)) is resting, (at, bottom)
        # paper, Rewards: yellow pays half its size and does not end the episode, so both can be eaten
        assert level_spec.max_food_reward == pytest.approx(2 + 3 / 2)


# ---------------------------------------------------------------- L3 Obstacles


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l3_transparent_wall_ahead_hides_the_green_and_obstacles_grow(difficulty):
    for level_spec in specs(3, difficulty, range(6)):
        agent = level_spec.agent
        (food,) = level_spec.foods
        glasses = [
            w
            for w in of_kind(level_spec, "transparent_wall")
            if math.isclose(w.position[0], agent.x) and math.isclose(w.position[1], agent.y + 20)
        ]
        # notes, L3: "a transparent wall (d+5 wide, d+6 high) 20 ahead with a green (size 2..3) 3 behind it"
        assert len(glasses) == 1, "no transparent wall 20 straight ahead of the agent"
        (glass,) = glasses
        assert glass.size[0] == difficulty + 5 and glass.size[2] == difficulty + 6
        assert food.kind == "food_green" and 2 <= food.size[0] <= 3
        assert food.position[0] == pytest.approx(glass.position[0])
        assert food.position[1] - (glass.position[1] + glass.size[1] / 2) == pytest.approx(3)
        # notes, L3: "plus round(0.4d) obstacles, half pushable planks (mass 10), half transparent
        # walls, each 6..10 x 10..13"
        planks = of_kind(level_spec, "plank")
        others = [w for w in of_kind(level_spec, "transparent_wall") if w is not glass]
        assert len(planks) + len(others) == round(0.4 * difficulty)
        assert len(planks) - len(others) in (0, 1)
        assert all(p.mass == 10 for p in planks) and all(w.mass == 0 for w in others)
        assert all(6 <= o.size[0] <= 10 and 10 <= o.size[2] <= 13 for o in planks + others)


def test_l3_obstacles_are_larger_at_the_top_difficulty():
    # paper, Test Bench L3: "As the difficulty increases, both the size of the walls and the number of
    # additional walls increase"
    def largest(difficulty):
        return max(o.size[0] * o.size[2] for s in specs(3, difficulty) for o in of_kind(s, "plank"))

    assert largest(10) > largest(3)


# ---------------------------------------------------------------- L4 Avoidance


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l4_tiles_holes_and_walls(difficulty):
    n = round(6 - 0.2 * difficulty)
    for level_spec in specs(4, difficulty):
        # notes, L4: "floor of n x n tiles, n = round(6 - 0.2d); 2 holes (d<=5) or 3; each hole is a
        # missing tile; plus round(0.2d+1) walls"; paper: "The test starts with two holes, and when the
        # difficulty exceeds 5, a third hole is introduced" (5 | 6 is a hair either side)
        assert level_spec.arena_size == (50, 50)
        assert level_spec.tiles == (n, n)
        assert len(set(level_spec.holes)) == (3 if difficulty > 5 else 2)
        assert all(0 <= i < n and 0 <= j < n for i, j in level_spec.holes)
        assert len(inner_walls(level_spec, "wall")) == round(0.2 * difficulty + 1)


def test_l4_holes_are_larger_at_the_top_difficulty():
    # paper, Test Bench L4: "As the difficulty increases, the holes become larger"
    def hole_width(difficulty):
        return 50 / spec(4, difficulty, 0).tiles[0]

    widths = [hole_width(d) for d in DIFFICULTIES]
    assert widths == sorted(widths) and widths[-1] > widths[0]


# ---------------------------------------------------------------- L5 Spatial reasoning


def maze_distances(level_spec, start):
    """Chunk-to-chunk steps along the maze from ``start``, read off the spec's walls alone: two
    neighbouring 30 x 30 chunks are joined where no maze wall covers the middle of their shared edge."""
    width, height = level_spec.arena_size
    columns, rows = round(width / 30), round(height / 30)
    walls = [w for w in of_kind(level_spec, "wall") if w.yaw == 0 and w.size[2] == 10]

    def blocked(x, y):
        return any(abs(x - w.position[0]) <= w.size[0] / 2 and abs(y - w.position[1]) <= w.size[1] / 2 for w in walls)

    def centre(cell):
        return -width / 2 + (cell[0] + 0.5) * 30, -height / 2 + (cell[1] + 0.5) * 30

    distance, queue = {start: 0}, deque([start])
    while queue:
        cell = queue.popleft()
        for step in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            other = (cell[0] + step[0], cell[1] + step[1])
            if not (0 <= other[0] < columns and 0 <= other[1] < rows) or other in distance:
                continue
            (ax, ay), (bx, by) = centre(cell), centre(other)
            if not blocked((ax + bx) / 2, (ay + by) / 2):
                distance[other] = distance[cell] + 1
                queue.append(other)
    return distance


def chunk_of(level_spec, x, y):
    return int((x + level_spec.arena_size[0] / 2) // 30), int((y + level_spec.arena_size[1] / 2) // 30)


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l5_maze_of_chunks_agent_and_green_farthest_apart(difficulty):
    for level_spec in specs(5, difficulty, range(4)):
        # notes, L5: "a maze of round(0.6d+4) chunks of 30 x 30 with walls 10 high; agent and green in
        # the two chunks farthest apart"
        assert level_spec.wall_height == 10
        assert all(math.isclose(side % 30, 0) for side in level_spec.arena_size)
        (food,) = level_spec.foods
        start = chunk_of(level_spec, level_spec.agent.x, level_spec.agent.y)
        reached = maze_distances(level_spec, start)
        assert len(reached) == round(0.6 * difficulty + 4)  # the chunks of the maze, all joined
        farthest = max(max(maze_distances(level_spec, cell).values()) for cell in reached)
        assert reached[chunk_of(level_spec, *food.position[:2])] == farthest


@pytest.mark.parametrize("difficulty", [0, 1, 2, 10])  # 1 | 2: a hair either side of "d>1"
def test_l5_extra_obstacles_only_above_difficulty_1(difficulty):
    for level_spec in specs(5, difficulty, range(6)):
        # notes, L5: "for d>1 extra planks, transparent and opaque walls that grow with d"
        extra = of_kind(level_spec, "plank", "transparent_wall") + [
            w for w in of_kind(level_spec, "wall") if w.size[2] != 10
        ]
        assert bool(extra) is (difficulty > 1)
    if difficulty == 10:
        kinds = {o.kind for s in specs(5, 10, range(6)) for o in of_kind(s, "plank", "transparent_wall", "wall")}
        assert {"plank", "transparent_wall", "wall"} <= kinds


# ---------------------------------------------------------------- L6 Robustness


def test_l6_picks_every_other_level_and_recolours_with_five_colours():
    inner = set()
    for level_spec in specs(6, 5, range(100)):
        # paper, Test Bench L6: "a random test from L0 to L11 being selected, and the colors of the test
        # objects changing to one of five randomly generated colors"; notes, L6: "picks a random other
        # level and cell; every object kind gets one of 5 randomly generated colours"
        assert level_spec.level == 6 and level_spec.inner is not None
        inner.add(level_spec.inner.level)
        assert len({rgba[:3] for rgba in level_spec.colours.values()}) <= 5
        assert {obj.kind for obj in level_spec.objects} <= set(level_spec.colours)
    assert inner == {0, 1, 2, 3, 4, 5, 8, 9, 10, 11, 12}  # every level but the two that wrap (L6, L7)


def test_l6_walls_are_taller_at_higher_difficulty():
    # notes, L6: "walls grow taller with the L6 difficulty"
    def lowest_wall(difficulty):
        return min(w.size[2] for s in specs(6, difficulty) for w in of_kind(s, "wall", "transparent_wall"))

    heights = [lowest_wall(d) for d in (0, 5, 10)]
    assert heights == sorted(heights) and heights[-1] > heights[0]


# ---------------------------------------------------------------- L7 Internal models


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l7_blackout_schedule(difficulty):
    for level_spec in specs(7, difficulty, range(4)):
        # notes, L7: "picks a random other level; the camera shows 5 s, then goes black for
        # floor(min(d+1.1, 10)) s, repeating"
        assert level_spec.inner is not None and level_spec.inner.level not in (6, 7)
        assert level_spec.blackout.light == 5
        assert level_spec.blackout.dark == math.floor(min(difficulty + 1.1, 10))


def test_l7_blackouts_last_longer_with_difficulty():
    # paper, Test Bench L7: "the frequency and duration of these blackouts increasing as the difficulty rises"
    darks = [spec(7, d, 0).blackout.dark for d in DIFFICULTIES]
    assert darks == sorted(darks) and darks[-1] > darks[0]


@pytest.mark.xfail(
    strict=True,
    reason="departure: the paper has blackouts grow more frequent with difficulty; the schedule (the "
    "notes' build: 5 s light, then longer dark) makes them rarer, 10 a minute at d=0, 4 at d=10",
)
def test_l7_blackouts_come_more_often_with_difficulty():
    # paper, Test Bench L7: "the frequency and duration of these blackouts increasing as the difficulty rises"
    per_minute = [60 / (spec(7, d, 0).blackout.light + spec(7, d, 0).blackout.dark) for d in DIFFICULTIES]
    assert per_minute[-1] > per_minute[0], per_minute


# ---------------------------------------------------------------- L8 Object permanence


def l8_parts(level_spec):
    (food,) = level_spec.foods
    occluder = next(w for w in of_kind(level_spec, "wall") if w.position[:2] == (0.0, 0.0))
    return food, occluder


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l8_food_slides_behind_the_occluder_at_the_papers_speed_and_the_pit_is_opposite(difficulty):
    sides = set()
    for level_spec in specs(8, difficulty, range(6)):
        food, occluder = l8_parts(level_spec)
        half = occluder.size[0] / 2
        # notes, L8: "arena 90 x 45; a green piece spawns on one side of a central occluding wall and
        # moves behind it at speed round(0.2d+4)"; paper: "the speed at which the food moves behind the
        # wall also increases"
        assert level_spec.arena_size == (90, 45)
        assert food.kind == "food_green" and level_spec.agent.y < occluder.position[1]
        assert abs(food.position[0]) > half  # in sight, beyond the wall's end
        assert food.behaviour["type"] == "slide" and food.behaviour["speed"] == round(0.2 * difficulty + 4)
        to_x, to_y = food.behaviour["to"]
        assert abs(to_x) < half and to_y > occluder.position[1]  # behind the wall, from the agent
        # "behind the wall a barrier separates the two halves, one holding the food, the other a pit"
        assert level_spec.holes
        nx = level_spec.tiles[0]
        tile = level_spec.arena_size[0] / nx
        for i, j in level_spec.holes:
            x = -level_spec.arena_size[0] / 2 + (i + 0.5) * tile
            y = -level_spec.arena_size[1] / 2 + (j + 0.5) * tile
            assert x * to_x < 0 and y > occluder.position[1]
        barrier = [w for w in of_kind(level_spec, "wall") if w.position[0] == 0 and w.position[1] > 0]
        assert barrier, "no barrier between the food's half and the pit's"
        sides.add(to_x > 0)
    assert sides == {True, False}


@pytest.mark.xfail(
    strict=True,
    reason="departure: the notes' L8 moves the food 'at speed round(0.2d+4) for 8 s'; here it slides a "
    "fixed 16 units (24 -> 8) and stops, 4 s at d=0 and 2.7 s at d=10",
)
@pytest.mark.parametrize("difficulty", [0, 10])
def test_l8_food_moves_for_8_seconds(difficulty):
    food, _ = l8_parts(spec(8, difficulty, 0))
    # notes, L8: "moves behind it at speed round(0.2d+4) for 8 s"
    travel = math.dist(food.position[:2], food.behaviour["to"])
    assert travel / food.behaviour["speed"] == pytest.approx(8)


# ---------------------------------------------------------------- L9 Numerosity

SECTORS = {"north": (0, 1), "east": (1, 0), "south": (0, -1), "west": (-1, 0)}


def sector_counts(level_spec) -> dict[str, int]:
    counts = dict.fromkeys(SECTORS, 0)
    for food in level_spec.foods:
        x, y = food.position[:2]
        name = next(n for n, (ux, uy) in SECTORS.items() if x * ux + y * uy > abs(y * ux - x * uy))
        counts[name] += 1
    return counts


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l9_sector_counts_up_to_the_papers_most_with_one_fullest(difficulty):
    # notes, L9: "four sectors around the agent, each with a random number of food pieces (up to
    # clamp(3 + floor(d/3), 2, 5) - 1)"; paper: "the number of food pieces in each sector increases";
    # "The agent must correctly choose the sector with the most food" (so there is one)
    most = min(max(3 + math.floor(difficulty / 3), 2), 5) - 1
    seen = []
    for level_spec in specs(9, difficulty, range(30)):
        counts = sector_counts(level_spec)
        assert (level_spec.agent.x, level_spec.agent.y) == (0, 0)
        assert all(0 <= c <= most for c in counts.values()), counts
        assert sorted(counts.values())[-2] < max(counts.values())
        (food,) = {(f.kind, f.size[0]) for f in level_spec.foods}
        value = food[1] if food[0] == "food_green" else food[1] / 2  # paper, Rewards
        assert level_spec.max_food_reward == pytest.approx(max(counts.values()) * value)
        seen.append(max(counts.values()))
    assert max(seen) == most


@pytest.mark.parametrize("difficulty", [0, 10])
def test_l9_each_door_closes_once_the_head_has_entered_its_sector(difficulty):
    for level_spec in specs(9, difficulty, range(4)):
        doors = [w for w in level_spec.objects if w.behaviour and w.behaviour["type"] == "door"]
        assert sorted(tuple(d.behaviour["direction"]) for d in doors) == sorted(SECTORS.values())
        for door in doors:
            ux, uy = door.behaviour["direction"]
            # paper, Test Bench L9: "Once the agent enters a sector, the opening will close." The opening
            # is the hub's side, 8 from the centre (the door 1 thick, its inner face at 9); the head has
            # entered once it is past that face by the body's reach (4.5: notes, Body, the rest "X" of
            # shins 3.5 out) and 1 more, so no foot is under the door: 9 + 4.5 + 1 = 14.5 from the centre.
            trigger = 14.5
            assert door.position[0] * ux + door.position[1] * uy == pytest.approx(8.5)
            assert behaviour_class(door) is Door
            gate = Door(door)
            assert not gate.entered((trigger - 1e-6) * ux, (trigger - 1e-6) * uy)
            assert gate.entered((trigger + 1e-6) * ux, (trigger + 1e-6) * uy)
            # "The agent must enter a sector and collect all the food within it": no piece before the line
            for food in level_spec.foods:
                if food.position[0] * ux + food.position[1] * uy > abs(food.position[1] * ux - food.position[0] * uy):
                    assert food.position[0] * ux + food.position[1] * uy - food.size[0] / 2 > trigger


# ---------------------------------------------------------------- L10 Causal reasoning


def trench_rows(level_spec) -> list[int]:
    rows = sorted({j for _, j in level_spec.holes})
    columns = level_spec.tiles[0]
    for row in rows:  # across the whole arena
        assert {i for i, j in level_spec.holes if j == row} == set(range(columns))
    return rows


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_l10_trench_plank_food_and_side_walls(difficulty):
    for level_spec in specs(10, difficulty, range(6)):
        rows = trench_rows(level_spec)
        tile = level_spec.arena_size[1] / level_spec.tiles[1]
        north = -level_spec.arena_size[1] / 2 + (rows[-1] + 1) * tile
        south = -level_spec.arena_size[1] / 2 + rows[0] * tile
        (plank,) = of_kind(level_spec, "plank")
        (food,) = level_spec.foods
        # notes, L10: "a trench of deadly floor across the arena (wider with d), a plank that can be
        # pushed over to bridge it, green on the far side"
        assert plank.mass > 0 and plank.behaviour["type"] == "hinge"
        assert plank.position[1] < south and level_spec.agent.y < south
        assert food.kind == "food_green" and food.position[1] > north
        # the pushed-over plank reaches across: it stands at least as tall as the trench is wide
        assert plank.size[2] > north - south
        # notes, L10: "d 4-7 add one wall beside the plank, d>=8 two" (3|4 and 7|8 a hair either side)
        side = inner_walls(level_spec, "wall", "transparent_wall")
        assert len(side) == (0 if difficulty < 4 else 1 if difficulty < 8 else 2)
        for wall in side:
            assert abs(wall.position[0] - plank.position[0]) < plank.size[0]


def test_l10_trench_is_wider_at_higher_difficulty():
    # paper, Test Bench L10: "the trench will gradually become wider"
    widths = [len(trench_rows(spec(10, d, 0))) for d in DIFFICULTIES]
    assert widths == sorted(widths) and widths[-1] > widths[0]


@pytest.mark.parametrize("difficulty", [4, 8, 10])
def test_l10_side_walls_are_transparent_with_the_papers_probability(difficulty):
    # notes, L10: "each transparent with probability 1.2 - 0.1d"
    walls = [w for s in specs(10, difficulty, range(60)) for w in inner_walls(s, "wall", "transparent_wall")]
    share = sum(w.kind == "transparent_wall" for w in walls) / len(walls)
    expected = min(1.2 - 0.1 * difficulty, 1.0)
    spread = 3 * math.sqrt(expected * (1 - expected) / len(walls))
    assert abs(share - expected) <= spread + 0.02, (share, expected, len(walls))


# ---------------------------------------------------------------- L11 Body awareness


@pytest.mark.parametrize("difficulty", [0, 10])
def test_l11_terrain_of_amplitude_2_and_one_green_at_least_15_away(difficulty):
    for level_spec in specs(11, difficulty):
        heights = [h for row in level_spec.heightfield for h in row]
        # notes, L11: "rough terrain (smooth noise, amplitude 2, ...), one green at least 15 from the agent"
        assert max(heights) - min(heights) == pytest.approx(2, abs=1e-3)
        (food,) = level_spec.foods
        assert food.kind == "food_green" and agent_to(level_spec, food) >= 15


def test_l11_terrain_is_rougher_at_higher_difficulty():
    # paper, Test Bench L11: "As the difficulty increases, the terrain becomes progressively rougher"
    def bumpiness(difficulty):
        total = 0.0
        for level_spec in specs(11, difficulty, range(6)):
            field = level_spec.heightfield
            total += sum(abs(a - b) for row in field for a, b in zip(row, row[1:]))
        return total

    rough = [bumpiness(d) for d in (0, 5, 10)]
    assert rough == sorted(rough) and rough[-1] > 1.5 * rough[0], rough
