"""Arena files (aaai.task.arena): the round trip, errors naming file and line, and loading everywhere."""

import csv
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from click.testing import CliRunner

import aaai  # noqa: F401 - registers the environments
from aaai.config import ConfigError
from aaai.levels import generate, level_ids
from aaai.scoring.evaluation import COLUMNS, LEGACY_COLUMNS, scored_episodes
from aaai.task.arena import load_arena, parse_arena, spec_to_arena
from aaai_cli.main import cli

ARENAS = Path(__file__).resolve().parent.parent / "configs" / "arenas"


def write(tmp_path: Path, text: str, name: str = "my_test.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("level", level_ids())
def test_round_trip_every_level(tmp_path, level):
    for difficulty, seed in ((0, 0), (5, 3), (10, 11)):
        spec = generate(level, difficulty, seed)
        loaded = load_arena(write(tmp_path, spec_to_arena(spec)), seed=99)  # the file's own seed wins
        assert loaded.digest() == spec.digest()
        assert loaded == spec  # tuples stay tuples, floats are exact


def test_cli_spec_yaml_round_trips(tmp_path):
    result = CliRunner().invoke(cli, ["spec", "L10", "-d", "4", "-s", "2", "--yaml"])
    assert result.exit_code == 0, result.output
    assert load_arena(write(tmp_path, result.output)).digest() == generate(10, 4, 2).digest()


BASE = """description: a test
category: obstacles
arena_walls: true
agent: {x: 0, y: -18, yaw: 1.5707963267948966}
objects:
"""


def test_randomisation_is_seeded_by_episode_seed_and_file_name(tmp_path):
    text = BASE + "  - {kind: food_green, position: [{uniform: [-10, 10]}, {choice: [5, 10]}, 1.5], size: [3, 3, 3]}\n"
    path = write(tmp_path, text)
    a, b, c = load_arena(path, 1), load_arena(path, 1), load_arena(path, 2)
    assert a == b and a.foods[0].position != c.foods[0].position
    other = load_arena(write(tmp_path, text, "other.yaml"), 1)
    assert other.foods[0].position != a.foods[0].position
    assert a.level == 3 and a.name == "obstacles" and a.seed == 1 and len(a.objects) == 5  # 4 arena walls
    xs = [load_arena(path, s).foods[0].position[0] for s in range(20)]
    assert all(-10 <= x <= 10 for x in xs) and len(set(xs)) == 20


def error_of(path: Path) -> str:
    with pytest.raises(ConfigError) as caught:
        load_arena(path)
    return str(caught.value)


def test_unknown_key_names_file_line_and_object(tmp_path):
    path = write(
        tmp_path,
        BASE + "  - {kind: food_green, position: [0, 5, 1.5], size: [3, 3, 3]}\n"
        "  - {kind: wall, position: [8, 0, 2], size: [4, 1, 4], colur: [1, 0, 0, 1]}\n",
    )
    message = error_of(path)
    assert message.startswith("my_test.yaml line 7, objects[1].colur: key 'colur' does not exist"), message
    top = write(tmp_path, "agnet: {x: 0, y: 0}\n" + BASE, "top.yaml")
    assert error_of(top).startswith("top.yaml line 1, agnet: key 'agnet' does not exist")


def test_wrong_type_names_file_line_and_field(tmp_path):
    path = write(tmp_path, BASE + "  - {kind: food_green, position: [0, five, 1.5], size: [3, 3, 3]}\n")
    message = error_of(path)
    assert message.startswith("my_test.yaml line 6, objects[0].position[1]: got 'five'; allowed: a finite number"), (
        message
    )
    bad_kind = write(tmp_path, BASE + "  - {kind: food_blue, position: [0, 5, 1.5], size: [3, 3, 3]}\n", "kind.yaml")
    assert error_of(bad_kind).startswith(
        "kind.yaml line 6, objects[0].kind: got 'food_blue'; allowed: one of food_green"
    )


def test_overlapping_objects_name_both(tmp_path):
    path = write(
        tmp_path,
        BASE + "  - {kind: food_green, position: [0, 12, 1.5], size: [3, 3, 3]}\n"
        "  - {kind: wall, position: [-8, 0, 2], size: [6, 1, 4]}\n"
        "  - {kind: wall, position: [-6, 0, 2], size: [6, 1, 4]}\n",
    )
    message = error_of(path)
    assert "my_test.yaml line 7, objects[1] (wall): at (-8.0, 0.0) overlaps objects[2] (wall)" in message, message


def test_unreachable_food_names_its_line(tmp_path):
    boxed = "".join(
        f"  - {{kind: wall, position: [{x}, {y}, 2], size: [{sx}, {sy}, 4]}}\n"
        for x, y, sx, sy in ((0, 6, 9, 1), (0, 14, 9, 1), (-4, 10, 1, 7), (4, 10, 1, 7))
    )
    path = write(tmp_path, BASE + boxed + "  - {kind: food_green, position: [0, 10, 1], size: [2, 2, 2]}\n")
    message = error_of(path)
    assert message.startswith("my_test.yaml line 10, objects[4] (food_green): at (0.0, 10.0) cannot be reached"), (
        message
    )


def test_agent_inside_a_wall(tmp_path):
    path = write(
        tmp_path,
        BASE + "  - {kind: wall, position: [0, -18, 2], size: [8, 1, 4]}\n"
        "  - {kind: food_green, position: [0, 12, 1.5], size: [3, 3, 3]}\n",
    )
    message = error_of(path)
    assert "my_test.yaml line 4, agent: the agent's start (0.0, -18.0) is not clear" in message, message


def test_yaml_limits_still_apply(tmp_path):
    path = write(tmp_path, "a: &x [1]\nb: *x\n")
    with pytest.raises(ConfigError, match="alias"):
        load_arena(path)


@pytest.mark.parametrize(
    "line, words",
    [
        ("seed: " + "7" * 5001, "an integer of 5,001 digits"),
        ("wall_height: 1.0e+999", "too large for a float"),
        ("extras: !!python/object/apply:os.system [echo]", "the tag !!python/object/apply:os.system is not allowed"),
        ('extras: {"a\\0": 1}', "a NUL character in a value"),
        ("extras: " + "[" * 30 + "]" * 30, "nests too deeply at line 5; allowed: 20 levels"),
    ],
    ids=["digits", "float", "python", "nul", "deep"],
)
def test_a_hostile_arena_file_gets_one_line_naming_the_file_and_the_line(tmp_path, line, words):
    path = write(tmp_path, BASE.split("objects:")[0] + line + "\nobjects: []\n")
    with pytest.raises(ConfigError) as error:
        load_arena(path)
    message = str(error.value)
    assert message.startswith(f"arena file {str(path)!r}") and "\n" not in message, message
    assert words in message and "line 5" in message, message


def test_gym_make_with_arena_uses_episode_seed(tmp_path):
    path = ARENAS / "l0_food_ahead.yaml"
    env = gym.make("aaai/AnimalAI-v0", arena=str(path), max_steps=20)
    try:
        _, info = env.reset(seed=4)
        assert env.unwrapped.level_spec == load_arena(path, 4)
        assert info["seed"] == 4 and info["level_name"] == "food_contact" and info["max_steps"] == 20
        for _ in range(3):
            env.step(env.action_space.sample())
        _, info = env.reset(seed=5)
        assert env.unwrapped.level_spec == load_arena(path, 5) != load_arena(path, 4)
    finally:
        env.close()
    with pytest.raises(ConfigError, match="my_test.yaml line"):
        gym.make("aaai/AnimalAI-v0", arena=str(write(tmp_path, BASE)))  # no food: refused at construction


def test_shipped_battery_is_valid():
    files = sorted(ARENAS.glob("*.yaml"))
    assert len(files) >= 24
    categories = {}
    for path in files:
        spec, meta, _ = parse_arena(path, 0)
        assert meta["description"] and "\n" not in meta["description"]
        categories[meta["category"]] = categories.get(meta["category"], 0) + 1
    assert len(categories) == 13 and min(categories.values()) >= 2
    result = CliRunner().invoke(cli, ["validate", "--arena", str(ARENAS), "--seeds", "3"])
    assert result.exit_code == 0, result.output
    assert f"{len(files)} arena files, 0 with problems" in result.output


def test_validate_arena_reports_problems(tmp_path):
    write(
        tmp_path,
        BASE + "  - {kind: wall, position: [0, -18, 2], size: [8, 1, 4]}\n"
        "  - {kind: food_green, position: [0, 12, 1.5], size: [3, 3, 3]}\n",
    )
    result = CliRunner().invoke(cli, ["validate", "--arena", str(tmp_path)])
    assert result.exit_code == 1
    assert "my_test.yaml line 4, agent" in result.output


def test_eval_arenas_writes_scoreboard_and_summary(tmp_path):
    config = write(tmp_path, "episode:\n  max_steps: 10\n", "short.yaml")
    out = tmp_path / "board.csv"
    result = CliRunner().invoke(
        cli,
        ["eval", "--arenas", str(ARENAS), "--policy", "random", "-k", "1", "--config", str(config), "--out", str(out)],
    )
    assert result.exit_code == 0, result.output
    with open(out, newline="") as handle:
        rows = list(csv.DictReader(handle))
    files = sorted(p.name for p in ARENAS.glob("*.yaml"))
    assert list(rows[0]) == COLUMNS and sorted(r["arena"] for r in rows) == files
    assert all(r["seed"] == "0" for r in rows)
    summary = (tmp_path / "board_summary.md").read_text()
    assert "| arena l3_transparent_detour.yaml | 1 |" in summary
    assert "| category L3 obstacles | 2 |" in summary and "| overall |" in summary
    again = CliRunner().invoke(
        cli,
        ["eval", "--arenas", str(ARENAS), "--policy", "random", "-k", "1", "--config", str(config), "--out", str(out)],
    )
    assert again.exit_code == 0 and len(scored_episodes(out)) == len(files)  # nothing played twice


def test_older_scoreboards_are_still_read(tmp_path):
    old = tmp_path / "old.csv"
    old.write_text(",".join(LEGACY_COLUMNS) + "\n" + "0,food_contact,0,1,0.5,2.5,0.2,failed,10,10,0,0,False,0.1\n")
    rows = scored_episodes(old)
    assert rows[0]["arena"] == "" and rows[0]["seed"] == "1"


def test_show_draws_a_shipped_arena(tmp_path):
    out = tmp_path / "arena.png"
    result = CliRunner().invoke(cli, ["show", "--arena", str(ARENAS / "l3_u_cup.yaml"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    import cv2

    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 100 and np.ptp(image) > 0
    neither = CliRunner().invoke(cli, ["show"])
    assert neither.exit_code == 2 and "LEVEL or an --arena" in neither.output


def test_run_with_arena():
    result = CliRunner().invoke(
        cli, ["run", "--arena", str(ARENAS / "l0_food_ahead.yaml"), "--max-steps", "10", "--episodes", "2"]
    )
    assert result.exit_code == 0, result.output
    assert result.output.count("l0_food_ahead.yaml") == 2


def test_arena_env_pickles_with_its_arena():
    import pickle

    from aaai.env import AnimalAIEnv

    path = str(ARENAS / "l2_y_maze_big_left.yaml")
    env = AnimalAIEnv(arena=path, max_steps=10)
    copy = pickle.loads(pickle.dumps(env))
    try:
        assert copy.arena == path
        copy.reset(seed=2)
        assert copy.level_spec == load_arena(path, 2)
    finally:
        env.close()
        copy.close()


def test_eval_arenas_honours_an_arenas_own_pass_mark(tmp_path):
    """Guards `aaai eval --arenas` with an arena's pass_mark (imported Animal-AI arenas carry one):
    a return at or above the mark passes whatever the ratio, below it fails."""
    source = sorted(ARENAS.glob("*.yaml"))[0].read_text()
    battery = tmp_path / "battery"
    battery.mkdir()
    (battery / "easy.yaml").write_text(source + "\npass_mark: -1000\n")
    (battery / "hard.yaml").write_text(source + "\npass_mark: 1000\n")
    (battery / "plain.yaml").write_text(source)
    config = write(tmp_path, "episode:\n  max_steps: 10\n", "short.yaml")
    out = tmp_path / "board.csv"
    result = CliRunner().invoke(
        cli,
        ["eval", "--arenas", str(battery), "--policy", "random", "-k", "1", "--config", str(config), "--out", str(out)],
    )
    assert result.exit_code == 0, result.output
    outcomes = {row["arena"]: row["outcome"] for row in scored_episodes(out)}
    assert outcomes == {"easy.yaml": "passed", "hard.yaml": "failed", "plain.yaml": "failed"}


def test_a_missing_or_broken_arena_file_is_named_as_an_arena_file(tmp_path):
    from aaai.env import AnimalAIEnv

    with pytest.raises(ConfigError, match=r"^arena file '.*missing.yaml' does not exist$"):
        AnimalAIEnv(arena=str(tmp_path / "missing.yaml"))
    broken = tmp_path / "broken.yaml"
    broken.write_text("arena: [")
    with pytest.raises(ConfigError, match=r"^arena file '.*broken.yaml' is not valid YAML"):
        AnimalAIEnv(arena=str(broken))


def test_a_hole_block_beyond_the_floor_or_too_many_objects_is_refused_before_it_is_built(tmp_path):
    head = "agent: {x: 0, y: 0}\ntiles: [10, 10]\n"
    huge = write(tmp_path, head + "holes: [{rect: [0, 0, 100000, 100000]}]\nobjects: []\n")
    with pytest.raises(ConfigError, match=r"holes\[0\].rect: got .*allowed: a block within the 10 x 10 floor tiles"):
        load_arena(huge, require_food=False)
    floor = "agent: {x: 0, y: 0}\ntiles: [400, 400]\nholes: [" + ", ".join(["{rect: [0, 0, 399, 399]}"] * 3) + "]\n"
    with pytest.raises(ConfigError, match=r"holes\[1\].rect: the holes list more than 160,000 tiles"):
        load_arena(write(tmp_path, floor + "objects: []\n"), require_food=False)
    many = write(tmp_path, head + "objects:\n" + "- {kind: wall, position: [0, 0, 1], size: [1, 1, 1]}\n" * 1001)
    with pytest.raises(ConfigError, match=r"line 3, objects: got 1,001 objects; allowed: at most 1000"):
        load_arena(many)


def channel(tmp_path: Path, width: float, beyond: str, pass_mark: float, pieces: int = 1) -> Path:
    """A channel ``width`` across the whole arena, the start at its foot, a green 10 across in its middle
    and ``pieces`` of ``beyond`` (5 across) past the green."""
    half = width / 2 + 0.5
    food = "".join(
        f"  - {{kind: {beyond}, shape: sphere, position: [0.0, {50.0 + 20 * i}, 2.5], size: [5.0, 5.0, 5.0]}}\n"
        for i in range(pieces)
    )
    return write(
        tmp_path,
        f"description: a channel {width} wide\narena_size: [200.0, 200.0]\ntime_limit: 100\n"
        f"pass_mark: {pass_mark}\nreach: pass_mark\nagent: {{x: 0.0, y: -90.0, yaw: 1.570796}}\nobjects:\n"
        f"  - {{kind: wall, position: [{-half}, 0.0, 5.0], size: [1.0, 200.0, 10.0], yaw: 0.0}}\n"
        f"  - {{kind: wall, position: [{half}, 0.0, 5.0], size: [1.0, 200.0, 10.0], yaw: 0.0}}\n"
        "  - {kind: food_green, shape: sphere, position: [0.0, 0.0, 5.0], size: [10.0, 10.0, 10.0]}\n" + food,
        name=f"channel_{width:g}.yaml",
    )


def test_a_pass_mark_that_needs_food_past_a_green_too_close_to_pass_is_refused(tmp_path):
    # the green (10 across) leaves (width - 10) / 2 on each side; the body needs its footprint (5) each way:
    # the reference passed the channels 32 and 33 wide (eating the yellow, then the green), in gait mode
    with pytest.raises(ConfigError, match=r"at most 9.00, below the pass mark 11 \(the pieces it needs lie past food"):
        load_arena(channel(tmp_path, 31, "food_yellow", 11))
    assert load_arena(channel(tmp_path, 32, "food_yellow", 11)).extras["pass_mark"] == 11
    # wide open, the same pieces are no problem
    load_arena(channel(tmp_path, 120, "food_yellow", 11))


def test_a_pass_mark_that_needs_a_green_and_the_last_multi_food_is_refused(tmp_path):
    # eating the last multi_food ends the episode as the green does: green and every multi_food cannot both be eaten
    with pytest.raises(ConfigError, match=r"at most 9.00, below the pass mark 12 \(the last multi_food piece eaten"):
        load_arena(channel(tmp_path, 120, "multi_food", 12))
    # with two pieces (5 each) one is left: the green (10) and the other give 15, less the step term's 1
    assert load_arena(channel(tmp_path, 120, "multi_food", 14, pieces=2)).extras["pass_mark"] == 14
    with pytest.raises(ConfigError, match=r"at most 14.00, below the pass mark 15 \(the last multi_food"):
        load_arena(channel(tmp_path, 120, "multi_food", 15, pieces=2))
