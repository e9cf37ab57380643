"""All thirteen level generators: registry, reproducibility, content, and solvability (aaai validate)."""

import subprocess
import sys
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from click.testing import CliRunner

import aaai  # noqa: F401  (registers the ids)
from aaai.config import ConfigError, load_config
from aaai.levels import InvalidLevelError, all_levels, generate, get_level, validate
from aaai.levels.common import arena_walls, slab, sphere
from aaai.registration import level_env_id
from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai_cli.main import cli

LEVELS = list(range(13))


def test_every_level_is_registered_with_its_label_and_gymnasium_id():
    assert sorted(all_levels()) == LEVELS
    assert [all_levels()[i].label for i in LEVELS] == [f"L{i}" for i in range(12)] + ["L2b"]
    assert get_level("L2b").name == "delayed_gratification" and get_level("y_maze").id == 2
    assert "aaai/L2b-DelayedGratification-v0" in gym.registry and "aaai/L11-BodyAwareness-v0" in gym.registry
    assert load_config(level=12).level == 12
    with pytest.raises(
        ConfigError,
        match="config key 'level': got 13, and level 13 does not exist; allowed: registered level ids 0 to 12",
    ):
        load_config(level=13)


@pytest.mark.parametrize("level", LEVELS)
def test_every_level_gives_the_same_spec_for_the_same_seed(level):
    for difficulty in (0, 5, 10):
        assert generate(level, difficulty, 77) == generate(level, difficulty, 77)
    assert len({generate(level, 5, seed).digest() for seed in range(6)}) == 6


def test_spec_hashes_are_the_same_in_two_separate_processes():
    cells = [(level, difficulty, 1000 + level) for level in LEVELS for difficulty in (0, 7, 10)]
    code = f"from aaai.levels import generate\nfor l, d, s in {cells!r}: print(generate(l, d, s).digest())"
    runs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
        for _ in range(2)
    ]
    assert runs[0] == runs[1] == [generate(*cell).digest() for cell in cells]


def test_aaai_validate_passes_every_level_and_difficulty_over_5_seeds():
    """Every cell a few seeds deep (the 1000 seeds of every cell are make test-long's)."""
    result = CliRunner().invoke(cli, ["validate", "--seeds", "5"])
    assert result.exit_code == 0, result.output
    rows = [line.split() for line in result.output.splitlines()[1:-1]]
    assert len(rows) == 13 * 11
    assert all(row[-3] == "5" and row[-1] == "0" for row in rows)
    assert result.output.splitlines()[-1].split()[1:] == ["715", result.output.splitlines()[-1].split()[2], "0"]


@pytest.mark.long
def test_aaai_validate_passes_1000_seeds_per_cell():
    result = CliRunner().invoke(cli, ["validate", "--seeds", "1000"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1].split()[-1] == "0"


def test_aaai_validate_refuses_bad_ranges():
    result = CliRunner().invoke(cli, ["validate", "--levels", "0-20"])
    assert result.exit_code != 0 and "--levels" in result.output and "0 to 12" in result.output


# --- the checks catch what they should -------------------------------------------------
def arena(*objects, agent=(0.0, -15.0, 0.0), **extra):
    foods = [o for o in objects if o.is_food]
    return LevelSpec(
        level=0,
        name="test",
        difficulty=0,
        seed=0,
        agent=AgentPose(*agent),
        objects=tuple(arena_walls((50.0, 50.0), 4.0)) + objects,
        max_food_reward=max([f.food_value for f in foods], default=0.0),
        **extra,
    )


def test_a_plain_level_is_valid():
    assert validate.check(arena(sphere("food_green", 0.0, 10.0, 2.0))) == []


@pytest.mark.parametrize(
    "spec, problem",
    [
        (
            arena(sphere("food_green", 0, 10, 2), slab("wall", 5, 0, 6, 1, 4), slab("wall", 5, 0, 6, 1, 4, yaw=1.0)),
            "solid objects overlap",
        ),
        (arena(sphere("food_green", 0, 10, 2), slab("wall", 0, 10, 6, 1, 4)), "cuts into wall"),
        (arena(sphere("food_green", 0, 10, 2), tiles=(5, 5), holes=((2, 3),)), "not on solid ground"),
        (arena(sphere("food_green", 0, 24.5, 2)), "outside the arena"),
        (arena(sphere("food_green", 0, 10, 2), slab("wall", 0, -15, 6, 1, 4)), "start"),
        (arena(sphere("food_green", 0, 10, 2), slab("wall", 0, 0, 50, 1, 4)), "cannot be reached"),
        (arena(sphere("food_green", 0, 10, 2), slab("wall", 0, 0, 34, 1, 4)), "cannot be reached"),  # gaps of 8
        (arena(sphere("food_green", 0, 10, 2), slab("wall", 0, 0, 30, 1, 4)), "cannot be reached"),  # gaps of 10
        # food the head could reach only by leaning in against the wall, a foot touching it
        (arena(sphere("food_green", 0, 23.4, 2)), "cannot be reached"),
        (
            arena(sphere("food_green", 0, 10, 2), tiles=(50, 50), holes=tuple((i, 24) for i in range(50))),
            "cannot be reached",
        ),
        (arena(ObjectSpec("food_green", "sphere", (0, 10, 3), (2, 2, 2))), "not on solid ground"),
    ],
)
def test_the_checks_find_each_kind_of_problem(spec, problem):
    problems = validate.check(spec)
    assert any(problem in text for text in problems), problems


def test_a_gap_wide_enough_for_the_walking_body_is_passable():
    assert validate.check(arena(sphere("food_green", 0, 10, 2), slab("wall", 0, 0, 28, 1, 4))) == []  # gaps of 11


def test_food_by_a_wall_is_valid_when_the_head_reaches_it_from_the_open_side():
    assert validate.check(arena(sphere("food_green", 0, 21.0, 2))) == []  # 4 from the wall: the head 6.5 away


def test_the_l10_trench_is_crossable_only_by_the_plank():
    spec = generate(10, 10, 4)
    assert validate.check(spec) == []
    assert spec.bridge is not None
    assert any("cannot be reached" in text for text in validate.check(replace(spec, bridge=None)))


def test_l9_doors_are_passable_in_the_search_but_solid_in_physics():
    spec = generate(9, 5, 4)
    closed = [replace(o, behaviour=None) if o.behaviour else o for o in spec.objects]
    assert validate.check(spec) == []
    assert any("cannot be reached" in text for text in validate.check(replace(spec, objects=tuple(closed))))


def test_a_level_that_fails_the_check_is_regenerated_deterministically(monkeypatch):
    real = validate.check
    calls = []

    def fails_first(spec):
        calls.append(spec)
        return ["made up"] if len(calls) % 2 == 1 else real(spec)

    monkeypatch.setattr(validate, "check", fails_first)
    first = generate(3, 6, 5)
    again = generate(3, 6, 5)
    rejected = calls[0]  # the first attempt of the first call, refused by the made-up problem
    assert first.regenerated == 1 and rejected.regenerated == 0
    assert first == again and first.digest() == again.digest()  # regenerating is deterministic too
    monkeypatch.setattr(validate, "check", real)
    plain = generate(3, 6, 5)
    assert plain == rejected and plain.regenerated == 0  # a first attempt that passes is kept
    assert real(first) == []  # the regenerated level is a valid one...
    # ... and another layout, not the rejected one with a counter added (the counter aside, specs compare whole)
    assert replace(first, regenerated=0) != rejected
    assert (first.agent, first.objects) != (rejected.agent, rejected.objects)


def test_a_level_that_cannot_be_made_valid_names_its_seed(monkeypatch):
    monkeypatch.setattr(validate, "check", lambda spec: ["always wrong"])
    with pytest.raises(InvalidLevelError, match=r"level L4 \(avoidance\) difficulty 3 seed 42: .*always wrong"):
        generate(4, 3, 42)


# --- what each level holds --------------------------------------------------------------
def test_l6_recolours_kinds_with_five_colours_and_raises_walls():
    for seed in range(6):
        spec = generate(6, 10, seed)
        inner = spec.inner
        assert inner.level not in (6, 7) and spec.level == 6
        colours = {tuple(rgba[:3]) for rgba in spec.colours.values()}
        assert len(colours) <= 5
        assert all(o.colour is not None for o in spec.objects)
        assert all(o.size[2] >= 10 for o in spec.objects if o.kind in ("wall", "transparent_wall"))
        assert generate(inner.level, inner.difficulty, inner.seed).foods == [
            replace(f, colour=None) for f in spec.foods
        ]


def test_l7_is_another_level_seen_through_a_camera_that_blacks_out():
    for difficulty in (0, 5, 10):
        spec = generate(7, difficulty, difficulty)
        inner = spec.inner
        assert spec.level == 7 and inner.level not in (6, 7)
        same = generate(inner.level, inner.difficulty, inner.seed)  # the level it wraps, as that level builds it
        assert (spec.agent, spec.objects, spec.holes, spec.max_food_reward) == (
            same.agent,
            same.objects,
            same.holes,
            same.max_food_reward,
        )
        assert same.blackout is None and spec.blackout.light > 0 and spec.blackout.dark > 0


@pytest.mark.parametrize("level", LEVELS)
def test_every_level_runs_headless_with_rays_and_camera_at_every_difficulty(make_env, level):
    env = make_env(rays=True, camera=True, camera_resolution=16)
    for difficulty in range(11):
        observation, info = env.reset(seed=difficulty, options={"level": level, "difficulty": difficulty})
        assert info["max_reward"] == pytest.approx(env.level_spec.max_food_reward - 0.5)
        for _ in range(3):
            observation, _, _, _, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(observation) and not info["blew_up"]


@pytest.mark.parametrize("level", [6, 7])
def test_every_reserved_seed_of_l6_and_l7_builds_its_inner_level_from_a_reserved_seed(level):
    from aaai.levels.seeds import RESERVED_SEEDS, reserved_seeds

    for difficulty in range(11):
        for seed in reserved_seeds(level, difficulty, 10):
            assert generate(level, difficulty, seed).inner.seed in RESERVED_SEEDS


def _inner_seeds_stay_in_training(count: int) -> None:
    from aaai.levels.seeds import TRAIN_SEEDS

    rng = np.random.default_rng(5)
    for index, seed in enumerate(rng.integers(TRAIN_SEEDS.start, TRAIN_SEEDS.stop, size=count)):
        level, difficulty = 6 + index % 2, index % 11
        assert generate(level, difficulty, int(seed)).inner.seed in TRAIN_SEEDS


def test_training_seeds_of_l6_and_l7_build_their_inner_levels_from_training_seeds():
    # 200 draws: an inner seed drawn anywhere in the 2**32 would land among the reserved (a tenth) at
    # once; the 10000 draws are make test-long's
    _inner_seeds_stay_in_training(200)


@pytest.mark.long
def test_10000_training_seeds_of_l6_and_l7_build_inner_levels_from_training_seeds():
    _inner_seeds_stay_in_training(10000)


def test_level_lists_on_the_command_line_take_ids_labels_and_names(tmp_path):
    """docs (Levels): every tool knows a level by its id, label and name, --levels lists too."""
    import yaml
    from click.testing import CliRunner

    from aaai_cli.main import cli

    runner = CliRunner()
    result = runner.invoke(cli, ["seeds", "--levels", "L2b,food_contact,3-4", "--difficulty", "0", "-k", "1"])
    assert result.exit_code == 0, result.output
    assert [line.split()[0] for line in result.output.splitlines()[1:]] == ["L0", "L3", "L4", "L2b"]
    run = tmp_path / "run"
    args = ["train", "--agent", "random", "--levels", "L2b", "--difficulty", "0", "--steps", "8", "--run", str(run)]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert yaml.safe_load((run / "config.yaml").read_text())["curriculum"]["levels"] == [12]
    refused = runner.invoke(cli, ["seeds", "--levels", "L2b,L99"])
    assert (
        refused.exit_code != 0
        and "no level 'L99'" in refused.output
        and "12 (L2b delayed_gratification)" in refused.output
    )


@pytest.mark.parametrize("level", LEVELS)
def test_a_levels_own_id_builds_that_level_and_refuses_another(level):
    label = all_levels()[level].label
    env_id = level_env_id(all_levels()[level])
    for named in (label, None):  # naming its own level, or none, is fine
        env = gym.make(env_id, level=named, render_mode="rgb_array_list")  # render modes as AnimalAIEnv's
        try:
            env.reset(seed=0)
            assert env.unwrapped.level_spec.level == level and len(env.render()) == 1
        finally:
            env.close()
    assert gym.spec(env_id).kwargs == {"level": level}  # as AnimalAIEnv(**kwargs) takes it
    other = (level + 1) % len(LEVELS)
    with pytest.raises(ConfigError, match=f"got level={other} for {env_id}; allowed: {label}"):
        gym.make(env_id, level=other)
