"""Property-based checks (Hypothesis): bad input gets a clear error or a valid result, never a
crash. Each property runs a fixed budget of examples, derandomised so that make test repeats."""

import math
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aaai.config import RULES, ConfigError, load_config, parse_int_set
from aaai.levels import validate
from aaai.spec import SHAPES, AgentPose, LevelSpec, ObjectSpec
from aaai.spec.kinds import OBJECT_KINDS

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
        taken = config.flat()[key]
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


# --- the command line's numbers: every number flag of every command ----------------------------
def _commands(group=None, path=()):
    import click

    from aaai_cli.main import cli

    group = cli if group is None else group
    for name, command in sorted(group.commands.items()):
        if isinstance(command, click.Group):
            yield from _commands(command, (*path, name))
        else:
            yield (*path, name), command


def _number_flags() -> list:
    import click

    from aaai_cli.options import SeedList

    kinds = (click.types.IntParamType, click.types.FloatParamType, SeedList)
    return [
        (path, command, option)
        for path, command in _commands()
        for option in command.params
        if isinstance(option, click.Option) and isinstance(option.type, kinds)
    ]


NUMBER_FLAGS = _number_flags()
odd_numbers = st.one_of(
    st.sampled_from(
        ["0", "1", "-1", "7", " 7", "", "x", "1e3", "0x10", "1_000", "nan", "inf", "-inf", "1e400", "0.5", "-0"]
        + ["99999999999999999999", str(2**31), str(2**32 - 1), str(2**32), str(2**63), "1,2", "1,-1", "reserved"]
    ),
    st.integers(-(2**70), 2**70).map(str),
    st.floats().map(str),
    st.text(alphabet="0123456789-+.,e ", max_size=8),
)


def test_every_number_flag_of_every_command_is_bounded():
    """A number flag declared without bounds (type=int, or a float that takes NaN) fails here."""
    import click

    from aaai_cli.options import SeedList

    assert len(NUMBER_FLAGS) >= 40 and {path for path, _, _ in NUMBER_FLAGS} >= {("run",), ("train",), ("eval",)}
    for path, command, option in NUMBER_FLAGS:
        where = (path, option.opts)
        if isinstance(option.type, SeedList):
            continue
        if isinstance(option.type, click.types.IntParamType):
            assert isinstance(option.type, click.IntRange), where
            assert option.type.min is not None and option.type.max is not None, where
        else:
            for value in ("nan", "inf", "-inf"):
                try:
                    option.type.convert(value, option, click.Context(command))
                except click.BadParameter:
                    continue
                raise AssertionError(f"{where} took {value}")


def _flag_takes_or_refuses(path, command, option, text) -> None:
    import click

    from aaai.levels import SEED_LIMIT
    from aaai_cli.options import SeedList

    try:
        value = option.type_cast_value(click.Context(command, info_name=" ".join(path)), text)
    except click.BadParameter as error:
        message = error.format_message()
        assert "\n" not in message and any(flag in message for flag in option.opts), (path, text, message)
        return
    if isinstance(option.type, SeedList):
        assert value in ("reserved", "train") or all(0 <= int(seed) < SEED_LIMIT for seed in value.split(","))
    elif isinstance(option.type, click.types.IntParamType):
        assert option.type.min <= value <= option.type.max, (path, option.opts, text, value)
        if option.name in ("seed", "first_seed"):  # a seed, not a count of them
            assert 0 <= value < SEED_LIMIT, (path, option.opts, text, value)
    else:
        assert math.isfinite(value), (path, option.opts, text, value)


@FUZZ
@given(st.sampled_from(NUMBER_FLAGS), odd_numbers)
def test_any_text_for_any_number_flag_is_taken_within_bounds_or_refused_naming_the_flag(flag, text):
    _flag_takes_or_refuses(*flag, text)


@pytest.mark.long
@settings(max_examples=5000, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(NUMBER_FLAGS), odd_numbers)
def test_any_text_for_any_number_flag_is_taken_within_bounds_or_refused_naming_the_flag_long(flag, text):
    _flag_takes_or_refuses(*flag, text)


def _output_flags() -> list:
    from aaai_cli.options import Output

    return [
        (path, option) for path, command in _commands() for option in command.params if isinstance(option.type, Output)
    ]


OUTPUT_FLAGS = _output_flags()


@pytest.mark.parametrize(
    "path, option", OUTPUT_FLAGS, ids=[f"{' '.join(path)} {option.opts[-1]}" for path, option in OUTPUT_FLAGS]
)
def test_an_output_that_is_a_device_or_inside_a_file_is_refused_naming_the_flag(tmp_path, path, option):
    """Once: eval --out /dev/null scored, and left /dev/null_scored_with.json behind."""
    from aaai_cli.main import cli

    (tmp_path / "file").write_text("")
    for value in ("/dev/null", str(tmp_path / "file" / "out")):
        args = [*path, option.opts[-1], value]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 2 and isinstance(result.exception, SystemExit), (args, result.output)
        assert f"'{option.opts[-1]}'" in result.output and f"got {value!r}" in result.output, result.output
    assert not list(Path("/dev").glob("null?*")), "something written beside /dev/null"
    assert [p.name for p in tmp_path.iterdir()] == ["file"]  # refused before any work


def test_run_refuses_a_seed_past_the_limit_naming_the_flag(tmp_path):
    from aaai_cli.main import cli

    for args in (["--seed", "99999999999999999999"], ["--seed", str(2**32 - 1), "--episodes", "2"]):
        result = CliRunner().invoke(cli, ["run", *args])
        assert result.exit_code == 2 and isinstance(result.exception, SystemExit), (args, result.output)
        assert "Invalid value for '--seed'" in result.output or "Invalid value for --seed" in result.output
        assert "4294967295" in result.output and "Traceback" not in result.output
    result = CliRunner().invoke(cli, ["run", "--seed", str(2**32 - 1), "--max-steps", "10"])
    assert result.exit_code == 0 and "4294967295" in result.output, result.output
