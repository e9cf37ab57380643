"""Property-based checks (Hypothesis) of files from outside: the safe YAML reader and
``aaai import-animalai`` on arbitrary text and YAML give plain data or one clear error, never a
traceback. Each property runs a fixed budget of examples, derandomised so that make test repeats."""

import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aaai.config import ConfigError
from aaai.safe_yaml import Limits, YAMLRefused, parse
from aaai.tools.animalai import ANIMALAI_TAGS, LIMITS, import_animalai

FUZZ = settings(max_examples=150, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
PLAIN = (str, int, float, bool, type(None))
# YAML's punctuation and the words it resolves, so that examples reach the parser's corners
TOKENS = list("[]{}:,-&*!|>'\"#?%@`\\ \n\t") + [
    "a",
    "0",
    "9" * 45,
    "1.0e+999",
    ".inf",
    "~",
    "null",
    "true",
    "<<",
    "&x ",
    "*x",
    "!!python/object:os.system ",
    "!Arena ",
    "!!binary ",
    "---\n",
    "\\0",
    "\\ud800",
    "\0",
    "0000-01-01",
    "2001-12-14",
    "  ",
]
yaml_like = st.lists(st.sampled_from(TOKENS), max_size=40).map("".join)


def plain(value, depth: int = 0) -> bool:
    """Is this plain data (what a user's YAML may give), within the depth limit?"""
    if isinstance(value, dict):
        return depth < 20 and all(isinstance(k, PLAIN) and plain(v, depth + 1) for k, v in value.items())
    if isinstance(value, list):
        return depth < 20 and all(plain(v, depth + 1) for v in value)
    return isinstance(value, PLAIN) or type(value).__module__ == "datetime"


@FUZZ
@given(st.one_of(st.text(max_size=60), yaml_like), st.booleans(), st.sampled_from([Limits(), LIMITS]))
def test_any_text_is_plain_data_or_one_clear_refusal(text, c_parser, limits):
    try:
        data, _ = parse(text, "file 'f.yaml'", limits, c_parser=c_parser)
    except YAMLRefused as error:
        message = str(error)
        assert message.startswith("file 'f.yaml' ") and "\n" not in message, message
    else:
        assert plain(data), data


leaves = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**12), 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from(["GoodGoal", "Wall", "Agent", "RipenGoal", "SignBoard", "SpawnerTree", "Ramp", "DeathZone"]),
)
trees = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(
            st.sampled_from(
                ["name", "positions", "sizes", "rotations", "colors", "x", "y", "z", "r", "g", "b", "t", "items"]
                + ["passMark", "blackouts", "symbolNames", "initialValues", "finalValues", "delays", "changeRates"]
            ),
            inner,
            max_size=5,
        ),
    ),
    max_leaves=30,
)
arena_keys = st.one_of(st.integers(-3, 300), st.text(max_size=8))


@pytest.fixture(scope="module")
def folder():
    with tempfile.TemporaryDirectory() as name:
        yield Path(name)


@FUZZ
@given(
    st.one_of(
        st.dictionaries(arena_keys, trees, min_size=1, max_size=3).map(
            lambda arenas: "!ArenaConfig\n" + yaml.safe_dump({"arenas": arenas}, allow_unicode=True)
        ),
        st.lists(st.sampled_from([*TOKENS, *ANIMALAI_TAGS, "arenas:", "items:", "name: GoodGoal"]), max_size=40).map(
            lambda tokens: "!ArenaConfig\n" + "".join(tokens)
        ),
    )
)
def test_the_importer_on_any_file_converts_or_skips_with_one_line_each(folder, text):
    source = folder / "any.yaml"
    source.write_text(text, encoding="utf-8", errors="surrogatepass")
    out = folder / "out"
    lines: list[str] = []
    try:
        results = import_animalai(source, out, echo=lines.append)
    except ConfigError as error:  # the source is neither a file nor a folder: never here
        pytest.fail(str(error))
    for result in results:
        if not result.problem:  # in out, or in out/unfair when it cannot be made fair for the body
            where = out / "unfair" / result.name if result.unfair else out / result.name
            assert where.resolve().parent == (out / "unfair" if result.unfair else out).resolve()
    written = {path.name for path in out.rglob("*.yaml")}
    assert written <= {result.name for result in results if not result.problem}
    for path in out.rglob("*.yaml"):
        path.unlink()
    assert lines and all("Traceback" not in line for line in lines)
