"""Animal-AI's battery made to fit our body: listed-frame blackouts, one time-limit rule, a start moved
clear, a larger scale for narrow passages, unfair tasks named, food out of reach as a lure, and the
coverage report (``aaai import-animalai --report``)."""

import copy
import csv

import pytest
import yaml
from click.testing import CliRunner
from conftest import AAI_AGENT, AAI_GOAL, AAI_WALL

from aaai.config import ConfigError
from aaai.sim.sensors import Blackout
from aaai.spec import Blackout as Schedule
from aaai.task.arena import load_arena, parse_arena
from aaai.tools.animalai import import_animalai
from aaai_cli.main import cli

HEAD = "!ArenaConfig\narenas:\n  0: !Arena\n"


def arena(body: str, head: str = "    t: 250\n") -> str:
    return HEAD + head + "    items:\n" + body


AGENT = AAI_AGENT
WALL, GOAL = AAI_WALL, AAI_GOAL
SIDES = ((30, 25, 6, 0.5), (30, 35, 6, 0.5), (27, 30, 0.5, 9.5), (33, 30, 0.5, 9.5))
BOX = "".join(WALL.format(x=x, z=z, sx=sx, sz=sz) for x, z, sx, sz in SIDES)  # walls round (30, 30)


def convert(tmp_path, files: dict, **options):
    source = tmp_path / "src"
    source.mkdir(parents=True)
    for name, text in files.items():
        (source / name).write_text(text)
    lines: list[str] = []
    results = import_animalai(source, tmp_path / "out", echo=lines.append, **options)
    return {r.name: r for r in results}, tmp_path / "out"


def test_blackouts_at_listed_frames_switch_the_light_at_those_steps(tmp_path):
    text = arena(AGENT.format(x=20, z=5, r=0) + GOAL.format(x=20, z=30), "    t: 250\n    blackouts: [15, 60, 80]\n")
    results, out = convert(tmp_path, {"dark.yaml": text})
    assert not results["dark.yaml"].problem
    spec = load_arena(out / "dark.yaml")
    frame = 0.128 * 5
    assert spec.blackout.switches == pytest.approx((15 * frame, 60 * frame, 80 * frame))
    camera = Blackout(spec.blackout, frame)  # a control step of one frame: dark from 15 to 59, and from 80 on
    assert [camera.dark(step) for step in (0, 14, 15, 59, 60, 79, 80, 500)] == [0, 0, 1, 1, 0, 0, 1, 1]
    assert Schedule(1.0, 2.0).__dict__ == {"light": 1.0, "dark": 2.0, "switches": ()}


def test_switches_out_of_order_are_refused_by_name(tmp_path):
    path = tmp_path / "a.yaml"
    path.write_text("agent: {x: 0, y: 0}\nobjects: []\nblackout: {switches: [5, 2]}\n")
    with pytest.raises(ConfigError, match=r"a.yaml line 3, blackout.switches: got \[5, 2\]; allowed: one or more"):
        parse_arena(path)


def test_a_periodic_blackout_keeps_its_digest():
    from aaai.levels import generate

    spec = generate(7, 0, 0)
    assert spec.blackout is not None and "switches" not in spec.to_json()


def test_time_limits_follow_one_rule(tmp_path):
    files = {
        f"t{t}.yaml": arena(AGENT.format(x=20, z=5, r=0) + GOAL.format(x=20, z=30), f"    t: {t}\n")
        for t in (250, 500, 1000)
    }
    _, out = convert(tmp_path, files)
    limits = [parse_arena(out / f"t{t}.yaml")[0].time_limit for t in (250, 500, 1000)]
    assert limits == pytest.approx([250 * 0.64, 500 * 0.64, 1000 * 0.64])  # t x 0.128 x scale, uncapped below 1000 s


def test_a_start_that_does_not_fit_moves_to_the_nearest_clear_place_facing_the_same_way(tmp_path):
    # Animal-AI's agent 1 unit from a wall: at scale 5 our body (10 across) does not fit there
    text = arena(AGENT.format(x=20, z=20, r=90) + WALL.format(x=20, z=18.5, sx=20, sz=1) + GOAL.format(x=5, z=35))
    results, out = convert(tmp_path, {"start.yaml": text})
    assert results["start.yaml"].changes == ["start moved (1.3 units, to clear the body)"]  # just enough
    spec = load_arena(out / "start.yaml")  # valid now
    moved = spec.extras["animalai"]["start_moved"]
    assert moved["from"] == [0.0, 0.0] and moved["to"] == [spec.agent.x, spec.agent.y]
    assert spec.agent.y - 0.0 == pytest.approx(1.3, abs=0.3)  # away from the wall at y -10 .. -5
    assert spec.agent.yaw == pytest.approx(0.0)  # rotation 90 (east), as before the move
    unfitted, out2 = convert(tmp_path / "plain", {"start.yaml": text}, fitted=False)
    with pytest.raises(ConfigError, match="is not clear"):
        load_arena(out2 / "start.yaml")


def test_a_passage_narrower_than_the_body_gets_a_larger_scale_recorded(tmp_path):
    # a wall across the arena with a gap of 1.9 Animal-AI units: 9.5 here at scale 5, too narrow
    walls = WALL.format(x=9.525, z=20, sx=19.05, sz=1) + WALL.format(x=30.475, z=20, sx=19.05, sz=1)
    text = arena(AGENT.format(x=20, z=5, r=0) + walls + GOAL.format(x=20, z=35))
    results, out = convert(tmp_path, {"gap.yaml": text})
    assert results["gap.yaml"].changes == ["scale 6 (passages narrower than the body at 5)"]
    spec = load_arena(out / "gap.yaml")
    assert spec.arena_size == (240.0, 240.0) and spec.extras["animalai"]["scale"] == 6
    assert spec.time_limit == pytest.approx(250 * 0.128 * 6)


def test_a_task_that_cannot_be_made_fair_is_kept_and_marked_with_the_reason(tmp_path):
    box = "".join(
        WALL.format(x=x, z=z, sx=sx, sz=sz)
        for x, z, sx, sz in ((30, 25, 6, 0.5), (30, 35, 6, 0.5), (27, 30, 0.5, 9.5), (33, 30, 0.5, 9.5))
    )
    text = arena(AGENT.format(x=5, z=5, r=0) + box + GOAL.format(x=30, z=30))
    results, out = convert(tmp_path, {"shut.yaml": text})
    assert results["shut.yaml"].unfair == ["food out of reach"]
    assert not (out / "shut.yaml").exists()  # kept apart, so that `aaai eval --arenas out` runs the fair ones
    spec, _, _ = parse_arena(out / "unfair" / "shut.yaml")
    assert spec.extras["animalai"]["unfair"].startswith("valid at no scale from 5 to 8: food out of reach")


def test_food_out_of_reach_is_a_lure_while_the_reachable_food_gives_the_pass_mark(tmp_path):
    box = "".join(
        WALL.format(x=x, z=z, sx=sx, sz=sz)
        for x, z, sx, sz in ((30, 25, 6, 0.5), (30, 35, 6, 0.5), (27, 30, 0.5, 9.5), (33, 30, 0.5, 9.5))
    )
    body = AGENT.format(x=5, z=5, r=0) + box + GOAL.format(x=30, z=30) + GOAL.format(x=10, z=20)
    results, out = convert(tmp_path, {"lure.yaml": arena(body, "    t: 250\n    pass_mark: 0\n")})
    assert not results["lure.yaml"].unfair and load_arena(out / "lure.yaml").extras["reach"] == "pass_mark"
    results, out = convert(tmp_path / "high", {"lure.yaml": arena(body, "    t: 250\n    pass_mark: 2\n")})
    assert results["lure.yaml"].unfair == ["reachable food below the pass mark"]
    with pytest.raises(
        ConfigError,
        match=r"food that can be reached gives at most 4.00, below the pass mark 8 \(1 piece of food out of reach\)",
    ):
        load_arena(out / "unfair" / "lure.yaml")


def test_a_pass_mark_above_all_the_arena_pays_is_marked_unfair_with_every_piece_in_reach(tmp_path):
    body = AGENT.format(x=5, z=5, r=0) + GOAL.format(x=20, z=20)  # one piece, in the open: worth 5 at scale 5
    results, out = convert(tmp_path, {"dear.yaml": arena(body, "    t: 250\n    pass_mark: 2\n")})
    assert results["dear.yaml"].unfair == ["reachable food below the pass mark"]
    with pytest.raises(ConfigError, match=r"at most 4.00, below the pass mark 8 \(all the arena's food, every piece"):
        load_arena(out / "unfair" / "dear.yaml")
    results, out = convert(tmp_path / "fair", {"fair.yaml": arena(body, "    t: 250\n    pass_mark: 1\n")})
    assert not results["fair.yaml"].unfair  # pass mark 3: the piece's 4 passes it


def test_the_report_counts_every_arena_by_cause(tmp_path):
    box = "".join(
        WALL.format(x=x, z=z, sx=sx, sz=sz)
        for x, z, sx, sz in ((30, 25, 6, 0.5), (30, 35, 6, 0.5), (27, 30, 0.5, 9.5), (33, 30, 0.5, 9.5))
    )
    source = tmp_path / "src"
    source.mkdir()
    (source / "01-1-1.yaml").write_text(arena(AGENT.format(x=20, z=5, r=0) + GOAL.format(x=20, z=30)))
    (source / "02-1-1.yaml").write_text(arena(AGENT.format(x=5, z=5, r=0) + box + GOAL.format(x=30, z=30)))
    (source / "03-1-1.yaml").write_text(arena("    - !Item\n      name: DataZone\n"))
    result = CliRunner().invoke(
        cli,
        [
            "import-animalai",
            str(source),
            "--out",
            str(tmp_path / "out"),
            "--report",
            str(tmp_path / "rep"),
            "--seeds",
            "2",
        ],
    )
    assert result.exit_code == 0, result.output
    rows = {r["source"]: r for r in csv.DictReader(open(tmp_path / "rep" / "coverage.csv"))}
    assert rows["01-1-1.yaml"]["valid_every_seed"] == "yes" and rows["01-1-1.yaml"]["valid_seeds"] == "2"
    assert rows["02-1-1.yaml"]["invalid_because"] == "food out of reach" and rows["02-1-1.yaml"]["unfair"]
    assert rows["02-1-1.yaml"]["file"] == "unfair/02-1-1.yaml" and rows["02-1-1.yaml"]["category"] == "02"
    assert rows["02-1-1.yaml"]["cause"] == "walled off" and rows["01-1-1.yaml"]["cause"] == ""
    assert (
        rows["03-1-1.yaml"]["converted"] == "no"
        and rows["03-1-1.yaml"]["not_converted_because"] == "data zones are not built here"
    )
    table = (tmp_path / "rep" / "coverage.md").read_text()
    assert "| converted | 2 | 66.7 % |" in table and "| valid on every seed 0 to 1 | 1 | 33.3 % of all |" in table
    assert (
        "| not valid on some seed: food out of reach | 1 |" in table
        and "| marked unfair: food out of reach | 1 |" in table
    )
    assert "| walled off | 1 | 02 1 |" in table and "| data zones are not built here | 1 | 03 1 |" in table


def test_a_wall_crossing_an_earlier_one_is_left_out_as_in_animal_ai_and_walls_cross_lets_a_file_keep_both(tmp_path):
    cross = WALL.format(x=20, z=30, sx=10, sz=1) + WALL.format(x=20, z=30, sx=1, sz=10)
    results, out = convert(
        tmp_path, {"cross.yaml": arena(AGENT.format(x=20, z=5, r=0) + cross + GOAL.format(x=5, z=20))}
    )
    assert not results["cross.yaml"].unfair
    data = yaml.safe_load((out / "cross.yaml").read_text())
    [wall] = [obj for obj in data["objects"] if obj["kind"] == "wall"]  # Animal-AI places the first only
    assert wall["size"][:2] == [50.0, 5.0] and data["extras"]["animalai"]["walls_left_out"][0]["item"] == 2
    assert data["walls_cross"] is True  # walls Animal-AI places as touching may overlap by its shrink here
    data["objects"].append({**copy.deepcopy(wall), "size": [5.0, 50.0, wall["size"][2]]})  # the crossing wall, by hand
    (out / "kept.yaml").write_text(yaml.safe_dump(data))
    assert load_arena(out / "kept.yaml").extras["walls_cross"] is True
    del data["walls_cross"]
    (out / "plain.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"objects\[0\] \(wall\): at \(0.0, 50.0\) overlaps objects\[2\] \(wall\)"):
        load_arena(out / "plain.yaml")


def test_eval_scores_the_imported_battery_by_the_olympics_categories(tmp_path):
    body = AGENT.format(x=20, z=5, r=0) + GOAL.format(x=20, z=30)
    files = {name: arena(body, "    t: 250\n    pass_mark: 0\n") for name in ("01-01-01.yaml", "04-02-03.yaml")}
    _, out = convert(tmp_path, files)
    config = tmp_path / "short.yaml"
    config.write_text("episode:\n  max_steps: 10\n")
    board = tmp_path / "board.csv"
    args = ["eval", "--arenas", str(out), "--policy", "random", "-k", "1", "--config", str(config), "--out", str(board)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    summary = (tmp_path / "board_summary.md").read_text()
    assert "| category 01 food retrieval | 1 |" in summary and "| category 04 avoidance | 1 |" in summary
    assert {row["outcome"] for row in csv.DictReader(open(board))} == {"failed"}  # below the pass mark in 10 steps


def test_a_low_wall_over_the_whole_arena_is_its_floor(tmp_path):
    floor = WALL.format(x=20, z=20, sx=40, sz=40).replace("y: 2", "y: 0.5")
    body = AGENT.format(x=20, z=5, r=0) + floor + GOAL.format(x=20, z=30)
    results, out = convert(tmp_path, {"floor.yaml": arena(body)})
    assert not results["floor.yaml"].unfair
    spec = load_arena(out / "floor.yaml")
    assert [obj.kind for obj in spec.objects[4:]] == ["food_green"]
    assert spec.objects[4].position[2] == pytest.approx(2.5)  # on the floor


def test_a_start_on_a_dividing_wall_is_not_moved_to_a_side_but_put_on_a_ledge(tmp_path):
    agent = "    - !Item\n      name: Agent\n      positions: [!Vector3 {x: 20, y: 1, z: 1}]\n      rotations: [0]\n"
    divide = (
        "    - !Item\n      name: Wall\n      positions: [!Vector3 {x: 20, y: 0, z: 20}]\n"
        "      sizes: [!Vector3 {x: 1, y: 1, z: 40}]\n      rotations: [0]\n"
    )
    pad = divide.replace("z: 20}]", "z: 1}]").replace("z: 40}", "z: 2}").replace("x: 1,", "x: 2,")
    results, out = convert(
        tmp_path,
        {
            "02-1-1.yaml": arena(agent + divide + GOAL.format(x=10, z=30)),
            "02-1-2.yaml": arena(agent + pad + GOAL.format(x=10, z=30)),
        },
    )
    assert not results["02-1-1.yaml"].unfair and "start on a ledge" in results["02-1-1.yaml"].changes
    text = (out / "02-1-1.yaml").read_text()
    assert "start_moved" not in text and "start_ledge: {at: [0.0, -94.0], height: 1.5, wall_top: 5.0}" in text
    spec = load_arena(out / "02-1-1.yaml")
    assert (spec.agent.x, spec.agent.y) == (0.0, -94.0) and spec.objects[-1].kind == "pillar"  # where it was
    assert not results["02-1-2.yaml"].unfair and any("start moved" in c for c in results["02-1-2.yaml"].changes)
