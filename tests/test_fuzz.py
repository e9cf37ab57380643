"""Property-based checks (Hypothesis): bad input gets a clear error or a valid result, never a
crash. Each property runs a fixed budget of examples, derandomised so that make test repeats."""

import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aaai.config import RULES, ConfigError, load_config, parse_int_set
from aaai.sim.kinds import OBJECT_KINDS
from aaai.spec import SHAPES, AgentPose, LevelSpec, ObjectSpec
from aaai.task import validate

FUZZ = settings(max_examples=150, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**30), 10**30))
values = st.one_of(numbers, st.booleans(), st.text(max_size=12), st.none(), st.lists(st.integers(-5, 20), max_size=4))


@FUZZ
@given(st.text(alphabet="0123456789-, x", max_size=24))
def test_any_range_text_is_parsed_within_bounds_or_refused_clearly(text):
    try:
        result = parse_int_set(text, "curriculum.levels", 0, 12)
    except ConfigError as error:
        assert "curriculum.levels" in str(error) and repr(text) in str(error)
    else:
        assert result and all(0 <= value <= 12 for value in result) and result == sorted(set(result))


@FUZZ
@given(st.sampled_from(sorted(RULES)), values)
def test_any_value_for_any_key_is_taken_or_refused_naming_the_key(key, value):
    short = key.rsplit(".", 1)[-1]
    try:
        config = load_config(**{short: value})
    except ConfigError as error:
        assert short in str(error)
    else:
        section, _, leaf = key.rpartition(".")
        taken = config[section][leaf] if section else config[leaf]
        assert taken is not None or RULES[key].kind == "path"  # a path key's null means "none" (train.init_from)


@st.composite
def objects(draw):
    return ObjectSpec(
        draw(st.sampled_from(OBJECT_KINDS)),
        draw(st.sampled_from(SHAPES)),
        tuple(draw(st.floats(-60, 60)) for _ in range(3)),
        tuple(draw(st.one_of(st.floats(0.01, 40), st.just(math.nan), st.just(math.inf))) for _ in range(3)),
        yaw=draw(st.floats(-4, 4)),
    )


@FUZZ
@given(
    st.lists(objects(), max_size=6),
    st.tuples(st.floats(-100, 1000), st.floats(-100, 1000)),
    st.tuples(st.floats(-60, 60), st.floats(-60, 60)),
    st.tuples(st.integers(1, 8), st.integers(1, 8)),
    st.lists(st.tuples(st.integers(-2, 10), st.integers(-2, 10)), max_size=4),
)
def test_validate_reports_problems_of_any_spec_and_never_crashes(items, arena, agent, tiles, holes):
    spec = LevelSpec(
        level=0,
        name="fuzz",
        difficulty=0,
        seed=0,
        agent=AgentPose(*agent, 0.0),
        objects=tuple(items),
        arena_size=arena,
        tiles=tiles,
        holes=tuple(holes),
    )
    problems = validate.check(spec)
    assert isinstance(problems, list) and all(isinstance(problem, str) for problem in problems)
