"""Food that ripens, decays, grows or shrinks (aaai.spec.kinds.TimedFood): its reward is its value at the
time it is eaten, and ripening and decaying food leave the episode running, growing and shrinking
food end it."""

import math

import numpy as np
import pytest
from conftest import open_arena, sphere

from aaai.levels import validate
from aaai.spec import ObjectSpec
from aaai.spec.kinds import REGISTRY
from aaai.task.arena import ArenaProblems, load_arena

STILL = np.zeros(8, np.float32)
TIMED = ("ripening_food", "decaying_food", "growing_food", "shrinking_food")


def timing_for(kind: str) -> dict:
    rising = REGISTRY[kind].rising
    return {"start": 1.0 if rising else 4.0, "end": 4.0 if rising else 1.0, "delay": 0.2, "duration": 0.4}


def eaten_at(env, kind: str, steps: int):
    """The food starts out of reach and is put against the head for the ``steps``-th step."""
    spec = open_arena(
        ObjectSpec(kind, "sphere", (-18.0, 18.0, 1.5), (3.0, 3.0, 3.0), timing=timing_for(kind)),
        sphere("food_green", 18.0, -18.0, 3.0),
    )
    env.reset(seed=0, options={"spec": spec, "check": False})
    body = next(b for b, obj in env.world.food.items() if obj.kind == kind)
    for _ in range(steps - 1):
        _, _, terminated, _, info = env.step(STILL)
        assert not terminated and info["reward_terms"]["food"] == 0
    env.world.place(body, (2.7, 0.0, 1.5), 0.0)
    return env.step(STILL)


@pytest.mark.parametrize("kind", TIMED)
def test_timed_food_pays_its_value_at_the_time_it_is_eaten(make_env, kind):
    env = make_env(limb_food_reward="none")
    dt = env.control_dt
    timing = timing_for(kind)
    start, end = timing["start"], timing["end"]
    # before the delay, halfway through the change, after it
    for seconds, value in ((0.1, start), (0.4, (start + end) / 2), (0.8, end)):
        steps = round(seconds / dt)
        _, _, terminated, _, info = eaten_at(env, kind, steps)
        assert info["reward_terms"]["food"] == pytest.approx(value, abs=1e-9), (kind, seconds)
        assert info["food_eaten"] == 1
        assert terminated == REGISTRY[kind].ends  # growing and shrinking food end it, like green
        if not REGISTRY[kind].ends:
            assert len(env.world.food) == 1  # taken out; the green is left


def test_a_timed_food_value_moves_in_a_straight_line_between_delay_and_end():
    obj = ObjectSpec(
        "ripening_food",
        "sphere",
        (0, 0, 1.5),
        (3, 3, 3),
        timing={"start": 0.0, "end": 10.0, "delay": 2.0, "duration": 5.0},
    )
    cls = REGISTRY["ripening_food"]
    assert [cls.value_at(obj, t) for t in (0, 2, 3, 4.5, 7, 100)] == [0, 0, 2, 5, 10, 10]
    assert obj.food_value == 10.0  # its best, for the level's best reward


@pytest.mark.parametrize(
    "kind,timing,words",
    [
        ("ripening_food", None, "timing is None"),
        ("ripening_food", {"start": 3, "end": 1, "delay": 0, "duration": 1}, "end above start"),
        ("decaying_food", {"start": 1, "end": 3, "delay": 0, "duration": 1}, "end below start"),
        ("growing_food", {"start": 1, "end": 3, "delay": -1, "duration": 1}, "delay 0 or more"),
        ("shrinking_food", {"start": 3, "end": 1, "delay": 0, "duration": 0}, "duration above 0"),
        ("growing_food", {"start": 1, "end": 3, "delay": 0}, "with start, end, delay, duration"),
        ("growing_food", {"start": 1, "end": "3", "delay": 0, "duration": 1}, "numbers"),
        ("growing_food", {"start": 1, "end": 199, "delay": 0, "duration": 1}, "0..100"),
        ("food_green", {"start": 1, "end": 3, "delay": 0, "duration": 1}, "timing only on ripening_food"),
    ],
)
def test_bad_timing_is_refused_naming_the_object_the_value_and_what_is_allowed(kind, timing, words):
    spec = open_arena(ObjectSpec(kind, "sphere", (10.0, 0.0, 1.5), (3.0, 3.0, 3.0), timing=timing))
    problems = [p for p in validate.check(spec) if kind in p]
    assert problems and words in problems[0] and "allowed" in problems[0], problems


def test_an_arena_file_takes_timing_and_refuses_it_when_wrong(tmp_path):
    text = """
agent: {x: 0, y: 0}
objects:
  - {kind: decaying_food, position: [10, 0, 1.5], size: [3, 3, 3], timing: {start: 5, end: 1, delay: 2, duration: 10}}
"""
    (tmp_path / "a.yaml").write_text(text)
    spec = load_arena(tmp_path / "a.yaml", 0)
    assert spec.foods[0].timing == {"start": 5, "end": 1, "delay": 2, "duration": 10}
    assert spec.max_food_reward == 5
    (tmp_path / "b.yaml").write_text(text.replace("end: 1", "end: 7"))
    with pytest.raises(ArenaProblems, match="timing"):
        load_arena(tmp_path / "b.yaml", 0)


def test_a_spec_without_timed_food_keeps_its_digest_keys():
    spec = open_arena(sphere("food_green", 10.0, 0.0, 3.0))
    assert "timing" not in spec.to_json()
    timed = open_arena(ObjectSpec("growing_food", "sphere", (10, 0, 1.5), (3, 3, 3), timing=timing_for("growing_food")))
    assert '"timing"' in timed.to_json() and math.isfinite(timed.foods[0].food_value)


# --- aaai import-animalai ---------------------------------------------------------------------
def test_animal_ai_goals_that_ripen_decay_grow_and_shrink_are_imported_with_their_timing(tmp_path):
    from pathlib import Path

    from aaai.tools.animalai import DEFAULT_SCALE as S
    from aaai.tools.animalai import import_animalai
    from aaai.tools.animalai_arena import SECONDS_PER_STEP

    fixtures = Path(__file__).with_name("fixtures") / "animalai_timed"
    lines = []
    import_animalai(fixtures, tmp_path, S, echo=lines.append)
    printed = "\n".join(lines)
    assert sorted(p.name for p in tmp_path.glob("*.yaml")) == ["timed_goals_a0.yaml"]
    assert (
        "arena 1, item 1 (RipenGoal): cannot be mapped (initialValues 3, finalValues 1; allowed: 0..5 with the "
        "final value above the initial)"
    ) in printed
    assert "arena 2, item 1 (ShrinkGoal): cannot be mapped (initialValues None, finalValues 1" in printed
    spec = load_arena(tmp_path / "timed_goals_a0.yaml", 0)
    by_kind = {obj.kind: obj for obj in spec.objects}
    frame = SECONDS_PER_STEP * S
    ripe = by_kind["ripening_food"]
    assert ripe.timing == pytest.approx({"start": S, "end": 3 * S, "delay": 100 * frame, "duration": 200 * frame})
    assert ripe.size == (3 * S,) * 3 and ripe.position[:2] == (-10 * S, 0.0)
    decay = by_kind["decaying_food"]  # the default delay, 150 frames; its size is its larger value's, not sizes'
    assert decay.timing == pytest.approx({"start": 4 * S, "end": 3 * S, "delay": 150 * frame, "duration": 200 * frame})
    assert decay.size == (4 * S,) * 3
    grow, shrink = by_kind["growing_food"], by_kind["shrinking_food"]
    assert grow.timing == pytest.approx({"start": S, "end": 3.5 * S, "delay": 0.0, "duration": 250 * frame})
    assert shrink.timing == pytest.approx(
        {"start": 2.5 * S, "end": 1.5 * S, "delay": 40 * frame, "duration": 5 * frame}
    )
    # the best reward: the better of the two ending foods, plus both that leave the episode running
    assert spec.max_food_reward == pytest.approx(3.5 * S + 3 * S + 4 * S)


def test_the_reference_eats_the_timed_food_of_its_animal_ai_style_arena_and_passes(make_env):
    from pathlib import Path

    from aaai.task.reference import ReferenceController
    from aaai.tools.animalai_coverage import passed

    path = Path(__file__).resolve().parents[1] / "configs" / "arenas" / "animalai" / "timed_food.yaml"
    env = make_env(action_mode="gait")
    spec = load_arena(path, 0)
    observation, _ = env.reset(seed=0, options={"spec": spec})
    controller = ReferenceController(env)
    controller.reset(0)
    total, eaten = 0.0, []
    while True:
        before = dict(env.world.food)
        observation, reward, terminated, truncated, info = env.step(controller(observation))
        total += reward
        for body in set(before) - set(env.world.food):
            eaten.append(before[body].kind)
        if terminated or truncated:
            break
    assert terminated and eaten[:2] in (["decaying_food", "ripening_food"], ["ripening_food", "decaying_food"])
    assert passed(total, spec), f"return {total:.2f} of {info['max_reward']:.2f}"


def test_the_solvability_check_requires_timed_food_to_be_reachable():
    ring = [
        ObjectSpec("wall", "box", (15.0, 0.0, 2.0), (1.0, 12.0, 4.0)),
        ObjectSpec("wall", "box", (5.0, 0.0, 2.0), (1.0, 12.0, 4.0)),
        ObjectSpec("wall", "box", (10.0, 5.5, 2.0), (11.0, 1.0, 4.0)),
        ObjectSpec("wall", "box", (10.0, -5.5, 2.0), (11.0, 1.0, 4.0)),
    ]
    food = ObjectSpec("growing_food", "sphere", (10.0, 0.0, 1.5), (3.0, 3.0, 3.0), timing=timing_for("growing_food"))
    assert validate.check(open_arena(food, agent=(-15.0, 0.0, 0.0))) == []
    problems = validate.check(open_arena(*ring, food, agent=(-15.0, 0.0, 0.0)))
    assert any("growing_food" in p and "cannot be reached" in p for p in problems), problems
