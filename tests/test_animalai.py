"""aaai import-animalai: Animal-AI arena files (fixtures in tests/fixtures/animalai, written in its
format) converted into aaai arena files."""

import math
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError
from aaai.task.arena import load_arena, parse_arena
from aaai.tools.animalai import DEFAULT_SCALE, convert_file, import_animalai
from aaai.tools.animalai_coverage import passed, reference_episode
from aaai_cli.main import cli

FIXTURES = Path(__file__).with_name("fixtures") / "animalai"
S = DEFAULT_SCALE


def imported(tmp_path, scale=S):
    lines = []
    results = import_animalai(FIXTURES, tmp_path / "out", scale, echo=lines.append)
    return results, "\n".join(lines), tmp_path / "out"


def test_several_arenas_become_several_files_and_an_unmappable_arena_is_skipped_by_name(tmp_path):
    results, printed, out = imported(tmp_path)
    assert sorted(p.name for p in out.glob("*.yaml")) == ["spawner_a0.yaml", "two_arenas_a0.yaml", "two_arenas_a1.yaml"]
    skipped = [r for r in results if r.problem]
    assert len(skipped) == 1
    assert "spawner.yaml, arena 1, item 2 (DataZone): cannot be mapped (data zones are not built here)" in printed
    assert "2 files, 4 arenas: 3 converted" in printed and "1 skipped" in printed
    assert "GoodGoal 2, GoodGoalMulti 1, HotZone 1, Wall 1" in printed  # the summary counts what converted


def test_positions_sizes_and_rotations_are_mapped_with_the_scale(tmp_path):
    _, _, out = imported(tmp_path)
    spec, meta, _ = parse_arena(out / "two_arenas_a0.yaml", 0)
    assert spec.arena_size == (40 * S, 40 * S)
    assert (spec.agent.x, spec.agent.y) == (0.0, -15 * S) and spec.agent.yaw == pytest.approx(math.pi / 2)
    by_kind = {obj.kind: obj for obj in spec.objects[4:]}  # after the arena's walls
    food = by_kind["food_green"]
    assert food.position == (0.0, 10 * S, S / 2) and food.size == (S, S, S) and food.shape == "sphere"
    wall = by_kind["wall"]
    assert wall.position == (-15 * S, 0.0, S) and wall.size == (6 * S, 1 * S, 2 * S)
    assert wall.yaw == pytest.approx(-math.pi / 2) and wall.colour == (1.0, 0.0, 0.0, 1.0)
    assert by_kind["bad_food"].position[:2] == (12 * S, 12 * S)
    zone = by_kind["hot_zone"]
    assert zone.size[:2] == (4 * S, 4 * S) and zone.size[2] <= 0.1
    assert spec.time_limit == pytest.approx(160.0) and spec.extras["pass_mark"] == pytest.approx(S - (S - 1) / 2)
    other, _, _ = parse_arena(out / "two_arenas_a1.yaml", 0)
    assert other.time_limit == pytest.approx(320.0) and other.extras["pass_mark"] == 0.0  # 500 steps; passMark spelling
    assert other.blackout is not None and other.blackout.light == other.blackout.dark
    tunnel = next(obj for obj in other.objects if obj.kind == "tunnel")
    assert tunnel.size == (3 * S, 4 * S, 4 * S) and tunnel.yaw == pytest.approx(0.0)  # its own +z turned to +x


def test_a_random_value_becomes_seeded_randomisation(tmp_path):
    _, _, out = imported(tmp_path)
    xs = {
        seed: [o for o in parse_arena(out / "two_arenas_a1.yaml", seed)[0].objects if o.kind == "multi_food"][
            0
        ].position[0]
        for seed in range(6)
    }
    assert len(set(xs.values())) > 1  # x was -1: drawn per episode seed
    assert all(abs(x) <= 20 * S for x in xs.values())
    again = [o for o in parse_arena(out / "two_arenas_a1.yaml", 3)[0].objects if o.kind == "multi_food"][0]
    assert again.position[0] == xs[3]  # the same seed, the same draw


def test_converted_arenas_validate(tmp_path):
    _, _, out = imported(tmp_path)
    for name in ("spawner_a0.yaml", "two_arenas_a0.yaml", "two_arenas_a1.yaml"):
        load_arena(out / name, 0)  # raises on any problem


@pytest.mark.long
def test_the_reference_passes_a_converted_arena(tmp_path, make_env):
    _, _, out = imported(tmp_path)
    spec = load_arena(out / "spawner_a0.yaml", 0)  # a green 20 Animal-AI units ahead
    env = make_env(action_mode="gait")
    total, ok = reference_episode(env, spec, 0)
    assert ok and total > S - 1
    assert not passed(-1.0, spec)  # standing still to the end fails


def test_the_scale_option_and_bad_input(tmp_path):
    _, _, out = imported(tmp_path, scale=3.0)
    assert parse_arena(out / "two_arenas_a0.yaml", 0)[0].arena_size == (120.0, 120.0)
    with pytest.raises(ConfigError, match="--scale"):
        import_animalai(FIXTURES, tmp_path / "x", 0.0)
    code = tmp_path / "code.yaml"
    code.write_text("!!python/object/apply:os.system ['echo hi']\n")
    with pytest.raises(ConfigError, match="code.yaml: not Animal-AI arena YAML"):
        convert_file(code)
    empty = tmp_path / "empty.yaml"
    empty.write_text("!ArenaConfig\narenas: {}\n")
    with pytest.raises(ConfigError, match="empty.yaml: got no 'arenas' mapping"):
        convert_file(empty)


def test_the_command(tmp_path):
    result = CliRunner().invoke(cli, ["import-animalai", str(FIXTURES / "two_arenas.yaml"), "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "1 files, 2 arenas: 2 converted" in result.output
    missing = CliRunner().invoke(cli, ["import-animalai", str(tmp_path / "nothing"), "--out", str(tmp_path)])
    assert missing.exit_code == 2 and "neither a file nor a folder" in missing.output


def test_a_goal_above_the_floor_lands_on_the_box_beneath_and_the_agent_starts_clear_of_the_wall(tmp_path):
    source = tmp_path / "falling.yaml"
    source.write_text("""!ArenaConfig
arenas:
  0: !Arena
    t: 250
    items:
    - !Item
      name: Agent
      positions:
      - !Vector3 {x: 20, y: 0, z: 0.5}
    - !Item
      name: Wall
      positions:
      - !Vector3 {x: 20, y: 0, z: 30}
      rotations: [0]
      sizes:
      - !Vector3 {x: 4, y: 2, z: 4}
    - !Item
      name: GoodGoal
      positions:
      - !Vector3 {x: 20, y: 5, z: 30}
      - !Vector3 {x: 10, y: 5, z: 10}
      sizes:
      - !Vector3 {x: 1, y: 1, z: 1}
      - !Vector3 {x: 1, y: 1, z: 1}
""")
    import_animalai(source, tmp_path / "out", echo=lambda line: None)
    spec, _, _ = parse_arena(tmp_path / "out" / "unfair" / "falling.yaml", 0)  # the food on the box: out of reach
    on_box, on_floor = [obj for obj in spec.objects if obj.kind == "food_green"]
    assert on_box.position[2] == pytest.approx(2 * S + S / 2) and on_floor.position[2] == pytest.approx(S / 2)
    assert spec.agent.y == pytest.approx(-20 * S + 6.0)  # 0.5 from the wall there, 6 here


def test_sign_boards_with_a_preset_symbol_convert_and_special_symbols_are_named(tmp_path):
    source = tmp_path / "signs.yaml"
    source.write_text("""!ArenaConfig
arenas:
  0: !Arena
    t: 250
    items:
    - !Item
      name: SignBoard
      positions:
      - !Vector3 {x: 20, y: 0, z: 30}
      rotations: [0]
      symbolNames: ["left-arrow"]
  1: !Arena
    t: 250
    items:
    - !Item
      name: SignPosterboard
      positions:
      - !Vector3 {x: 20, y: 0, z: 30}
      symbolNames: ["1/0/1/0/1"]
""")
    lines = []
    import_animalai(source, tmp_path / "out", echo=lines.append, fitted=False)  # the mapping alone
    sign = parse_arena(tmp_path / "out" / "signs_a0.yaml", 0)[0].objects[4]
    assert sign.kind == "sign_left_arrow" and sign.size[1:] == (1.4 * S, 1.4 * S)
    assert sign.yaw == pytest.approx(math.pi / 2)  # Animal-AI's forward (+z) is our north
    assert "signs.yaml, arena 1, item 0 (SignPosterboard): cannot be mapped (symbol '1/0/1/0/1'" in "\n".join(lines)


def test_an_item_stands_for_as_many_objects_as_its_longest_list(tmp_path):
    source = tmp_path / "five.yaml"
    source.write_text("""!ArenaConfig
arenas:
  0: !Arena
    t: 250
    items:
    - !Item
      name: GoodGoalMulti
      sizes:
      - !Vector3 {x: 1, y: 1, z: 1}
      - !Vector3 {x: 1, y: 1, z: 1}
      - !Vector3 {x: 2, y: 2, z: 2}
""")
    import_animalai(source, tmp_path / "out", echo=lambda line: None)
    foods = [o for o in parse_arena(tmp_path / "out" / "five.yaml", 0)[0].objects if o.kind == "multi_food"]
    assert [food.size[0] for food in foods] == [S, S, 2 * S]  # positions drawn at random for each


def walls(*entries: tuple[float, float, float, float]) -> str:
    """An arena's items: one Wall item of entries (x, y, z, size x), 1 deep and 1 high, unturned."""
    text = "    - !Item\n      name: Wall\n      positions:\n"
    text += "".join(f"      - !Vector3 {{x: {x}, y: {y}, z: {z}}}\n" for x, y, z, _ in entries)
    text += "      rotations: [" + ", ".join("0" for _ in entries) + "]\n      sizes:\n"
    text += "".join(f"      - !Vector3 {{x: {w}, y: 1, z: 1}}\n" for *_, w in entries)
    return text


@pytest.mark.parametrize(
    "cut, left_out",
    [(0.0019, False), (0.0021, True), (1.0, True)],  # a hair either side of Animal-AI's shrink (0.002), a crossing
)
def test_a_wall_crossing_a_wall_before_it_is_left_out_as_animalai_leaves_it_and_touching_walls_are_both_placed(
    tmp_path, cut, left_out
):
    # two walls 2 wide side by side along x: the second starts `cut` inside the first (9..11, then 11 - cut ..);
    # Animal-AI shrinks each to 0.999 of its size before it tests, so they must overlap by more than 0.002
    source = tmp_path / "walls.yaml"
    source.write_text(arena_config(("0", walls((10, 0, 20, 2), (12 - cut, 0, 20, 2), (10, 1, 20, 2)) + GOAL)))
    [result] = import_animalai(source, tmp_path / "out", echo=lambda line: None)
    spec, _, _ = parse_arena(tmp_path / "out" / "walls.yaml", 0)
    placed = sorted(o.position for o in spec.objects[4:] if o.kind == "wall")  # after the arena's four walls
    expected = [(-50.0, 0.0, 2.5), (-50.0, 0.0, 7.5)] + ([] if left_out else [(round(-40 - 5 * cut, 4), 0.0, 2.5)])
    assert placed == sorted(expected)  # the wall stacked on the first (y: 1, its top) is placed: the shrink parts them
    record = spec.extras.get("animalai", {}).get("walls_left_out")
    assert record == ([{"item": 0, "entry": 1, "position": [round(-40 - 5 * cut, 4), 0.0]}] if left_out else None)
    assert result.changes == (["wall crossing an earlier wall left out, as in Animal-AI (1 wall)"] if left_out else [])


# --- files from outside: nothing written outside --out, every attack one line, in bounded time ----
def arena_config(*arenas: tuple[str, str]) -> str:
    """An !ArenaConfig of arenas given as (key, items text)."""
    text = "!ArenaConfig\narenas:\n"
    for key, items in arenas:
        text += f"  {key}: !Arena\n    t: 250\n    items:\n{items}"
    return text


GOAL = "    - !Item\n      name: GoodGoal\n      positions:\n      - !Vector3 {x: 20, y: 0, z: 30}\n"


def run_import(tmp_path, text: str, name: str = "attack.yaml"):
    source = tmp_path / "in" / name
    source.parent.mkdir(exist_ok=True)
    source.write_text(text)
    out = tmp_path / "deep" / "out"
    started = time.perf_counter()
    result = CliRunner().invoke(cli, ["import-animalai", str(source), "--out", str(out)])
    return result, out, time.perf_counter() - started


def files_under(folder: Path) -> set[Path]:
    return {path for path in folder.rglob("*") if path.is_file()}


@pytest.mark.parametrize("key", ['"/../../evil"', '"../evil"', "a/b", '"x\\ty"', "'" + "k" * 65 + "'", "true"])
def test_an_arena_key_that_is_no_plain_name_is_refused_and_nothing_is_written_outside(tmp_path, key):
    before = files_under(tmp_path)
    result, out, _ = run_import(tmp_path, arena_config((key, GOAL), ("0", GOAL)))
    assert result.exit_code == 1, result.output
    assert "is not a plain name; allowed: 1 to 64 letters, digits, _ or -" in result.output
    assert result.output.count("SKIPPED") == 1 and "Traceback" not in result.output
    assert files_under(tmp_path) - before == {tmp_path / "in" / "attack.yaml"}  # nothing written, in --out or not


def test_a_name_leading_out_of_out_through_a_link_is_refused(tmp_path):
    outside = tmp_path / "outside.yaml"
    outside.write_text("mine\n")
    out = tmp_path / "deep" / "out"
    out.mkdir(parents=True)
    (out / "attack_a1.yaml").symlink_to(outside)
    result, out, _ = run_import(tmp_path, arena_config(("0", GOAL), ("1", GOAL)))
    assert result.exit_code == 1 and "attack_a1.yaml lies outside" in result.output, result.output
    assert outside.read_text() == "mine\n" and (out / "attack_a0.yaml").is_file()


def test_two_files_of_one_name_do_not_overwrite_each_other(tmp_path):
    for folder in ("a", "b"):
        (tmp_path / "src" / folder).mkdir(parents=True)
        (tmp_path / "src" / folder / "same.yaml").write_text(arena_config(("0", GOAL)))
    lines: list[str] = []
    results = import_animalai(tmp_path / "src", tmp_path / "out", echo=lines.append)
    assert [r.problem for r in results][0] == ""
    assert "b/same.yaml" not in "".join(lines) and "same.yaml was already written from same.yaml, arena 0" in lines[0]


def laughs_arena() -> str:
    """A bomb of 532 bytes that expands to 10**8 values: each list aliases the one before ten times."""
    text = "!ArenaConfig\narenas:\n  0: !Arena\n    l0: &l0 [x, x, x, x, x, x, x, x, x, x]\n"
    for level in range(1, 8):
        text += f"    l{level}: &l{level} [" + ", ".join([f"*l{level - 1}"] * 10) + "]\n"
    return text + "    items: *l7\n"


POSITIONS = "[" + ", ".join(["{x: 1, y: 0, z: 1}"] * 2000) + "]"  # 40 kB
ATTACKS = {
    "bomb": (laughs_arena(), "more than 100,000 values once its aliases are expanded"),
    "aliased positions": (
        "!ArenaConfig\narenas:\n  0: !Arena\n    p: &p "
        + POSITIONS
        + "\n    items:\n"
        + "".join("    - !Item {name: GoodGoal, positions: *p}\n" for _ in range(100)),
        "more than 100,000 values once its aliases are expanded",
    ),
    "deep list": ("!ArenaConfig\narenas: " + "[" * 50000 + "]" * 50000 + "\n", "nests too deeply at line 2"),
    "deep block": ("!ArenaConfig\narenas:\n" + "".join("  " * i + "-\n" for i in range(40)), "nests too deeply"),
    "NUL in a key": (arena_config(('"a\\0b"', GOAL)), "line 3: a NUL character in a value"),
    "NUL byte": (arena_config(("a\0b", GOAL)), "line 3: the character U+0000 is not allowed"),
    "5001 digits": (arena_config(("0", GOAL)).replace("t: 250", "t: " + "9" * 5001), "an integer of 5,001 digits"),
    "overflowing float": (arena_config(("0", GOAL)).replace("t: 250", "t: 1.0e+400"), "too large for a float"),
    "python tag": ("!ArenaConfig\narenas: !!python/object/apply:os.system [echo]\n", "the tag !!python/object/apply"),
}


@pytest.mark.parametrize("attack", sorted(ATTACKS))
def test_an_attack_gets_one_line_naming_the_file_in_bounded_time(tmp_path, attack):
    text, words = ATTACKS[attack]
    result, out, seconds = run_import(tmp_path, text)
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    skipped = [line for line in result.output.splitlines() if line.startswith("SKIPPED")]
    assert skipped == [f"SKIPPED attack.yaml: not Animal-AI arena YAML: {skipped[0].split(': ', 2)[2]}"]
    assert words in skipped[0] and len(result.output) < 1000, result.output
    assert seconds < 5 and not list(out.glob("*"))


def test_aliases_within_the_budget_are_read_and_an_arena_of_too_many_objects_is_skipped(tmp_path):
    reused = "!ArenaConfig\narenas:\n  0: !Arena\n    t: 250\n    p: &p [{x: 20, y: 0, z: 30}]\n    items:\n"
    reused += "    - !Item {name: GoodGoal, positions: *p}\n"
    result, out, _ = run_import(tmp_path, reused)
    assert result.exit_code == 0 and (out / "attack.yaml").is_file(), result.output
    many = "!ArenaConfig\narenas:\n  0: !Arena\n    p: &p " + POSITIONS + "\n    items:\n"
    many += "".join("    - !Item {name: GoodGoal, positions: *p}\n" for _ in range(2))
    result, out, seconds = run_import(tmp_path, many, "many.yaml")
    assert result.exit_code == 1 and "many.yaml, arena 0: 4,000 objects; allowed: at most 500" in result.output
    assert seconds < 5 and not (out / "many.yaml").exists()


def test_a_skipped_arena_is_named_in_a_short_line_however_large_its_value(tmp_path):
    text = "!ArenaConfig\narenas:\n  0: !Arena\n    p: &p " + POSITIONS + "\n    items: {a: *p, b: *p}\n"
    result, _, _ = run_import(tmp_path, text)
    assert result.exit_code == 1 and "attack.yaml, arena 0: items must be a list, got {'a': [" in result.output
    assert len(result.output) < 1000, result.output


def test_a_negative_pass_mark_is_passed_by_standing_still_here_only_where_it_is_in_animalai(tmp_path, make_env):
    """Animal-AI's agent that eats nothing ends an episode at -1 (its time cost), ours at -0.5 to -1:
    a pass mark a hair above -1 must fail it, a hair below pass it (physics: the body stands still to
    the time limit, 20 of Animal-AI's steps, with the food out of its way)."""
    import numpy as np

    results = {}
    for mark in (-0.99, -1.01):
        source = tmp_path / f"still{mark}.yaml"
        source.write_text(
            "!ArenaConfig\narenas:\n  0: !Arena\n"
            f"    pass_mark: {mark}\n    t: 20\n    items:\n"
            "    - !Item\n      name: Agent\n      positions:\n      - !Vector3 {x: 20, y: 0, z: 5}\n"
            "      rotations: [0]\n"
            "    - !Item\n      name: GoodGoal\n      positions:\n      - !Vector3 {x: 20, y: 0, z: 35}\n"
            "      sizes:\n      - !Vector3 {x: 1, y: 1, z: 1}\n"
        )
        (converted,) = convert_file(source, fitted=False)
        (tmp_path / converted.name).write_text(converted.text)
        spec = load_arena(tmp_path / converted.name, 0)
        env = make_env(action_mode="gait")
        env.reset(seed=0, options={"spec": spec, "check": False})
        total, done = 0.0, False
        while not done:
            _, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
            total += reward
            done = terminated or truncated
        assert info["food_eaten"] == 0 and not info["fell"] and -1.0 <= total <= -0.5, total
        results[mark] = passed(total, spec)
    assert results == {-0.99: False, -1.01: True}
