"""aaai.safe_yaml: YAML from outside is plain data; a hostile file gets one message naming it, the
line and what is allowed, in bounded time and memory, with libyaml's parser and with PyYAML's."""

import tracemalloc
from pathlib import Path

import pytest
import yaml

from aaai import safe_yaml
from aaai.config import ConfigError, config_dir
from aaai.safe_yaml import Limits, YAMLRefused, load, load_mapping, parse

PARSERS = pytest.mark.parametrize("c_parser", [True, False], ids=["libyaml", "python"])
LABEL = "config file 'x.yaml'"


def laughs(levels: int = 9, width: int = 10) -> str:
    """A "billion laughs" file: each list holds ``width`` aliases of the one before (10**9 values)."""
    text = "a0: &a0 [" + ", ".join(["lol"] * width) + "]\n"
    for level in range(1, levels):
        text += f"a{level}: &a{level} [" + ", ".join([f"*a{level - 1}"] * width) + "]\n"
    return text


HOSTILE = [
    ("a: &x [1, 2]\nb: *x\n", Limits(), 2, ["an alias (*name) is not allowed here"]),
    (laughs(), Limits(aliases=1000), 6, ["more than 1,000,000 values once its aliases are expanded"]),
    (laughs(), Limits(aliases=20), 4, ["more than 20 aliases"]),
    ("a: &x [1, *x]\n", Limits(aliases=5), 1, ["the alias *x is inside the value it names"]),
    ("a: !!python/object/apply:os.system ['echo hi']\n", Limits(), 1, ["the tag !!python/object/apply:os.system"]),
    ("a: !!python/name:os.system\n", Limits(), 1, ["the tag !!python/name:os.system is not allowed"]),
    ("a: !!binary aGk=\n", Limits(), 1, ["the tag !!binary is not allowed; allowed: plain YAML without tags"]),
    ("a: !Arena {}\n", Limits(), 1, ["the tag !Arena is not allowed"]),
    ("a: 1\nb: c\x00d\n", Limits(), 2, ["U+0000 is not allowed", "no NUL"]),
    ('a: 1\n"b\\0c": 2\n', Limits(), 2, ["a NUL character in a value"]),
    ('a: "\\ud800"\n', Limits(), 1, ["line 1"]),  # libyaml refuses it as it parses
    ("a: " + "9" * 5001 + "\n", Limits(), 1, ["an integer of 5,001 digits", "allowed: at most 40"]),
    ("a: 0x" + "f" * 60 + "\n", Limits(), 1, ["an integer of 62 digits"]),
    ("a: -1.0e+999\n", Limits(), 1, ["too large for a float"]),
    ("a: 0000-01-01\n", Limits(), 1, ["cannot be read as timestamp (year 0 is out of range)"]),
    ("[" * 5000 + "]" * 5000, Limits(), 1, ["nests too deeply", "allowed: 20 levels"]),
    ("".join("  " * i + "-\n" for i in range(200)), Limits(), 21, ["nests too deeply at line 21"]),
    ("? [1, 2]\n: 3\n", Limits(), 1, ["a key that is a list; allowed: keys that are text or numbers"]),
    ("a: 1\n---\nb: 2\n", Limits(), 2, ["a second document"]),
    ("a: [1,\nb: 2\n", Limits(), 3, ["is not valid YAML: line 3, column 1", "(while parsing a flow sequence)"]),
    ("a: *nowhere\n", Limits(aliases=3), 1, ["is not valid YAML", "*nowhere names no anchor"]),
]


@PARSERS
@pytest.mark.parametrize(
    "text, limits, line, words", HOSTILE, ids=[f"{i}-{words[0][:20]}" for i, (_, _, _, words) in enumerate(HOSTILE)]
)
def test_a_hostile_text_gets_one_line_naming_the_file_and_the_line(text, limits, line, words, c_parser):
    tracemalloc.start()
    try:
        with pytest.raises(YAMLRefused) as error:
            parse(text, LABEL, limits, c_parser=c_parser)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    message = str(error.value)
    assert message.startswith(LABEL) and "\n" not in message, message
    assert error.value.line == line and (f"line {line}" in message), message
    assert all(word in message for word in words), message
    assert isinstance(error.value, ConfigError)  # the CLI and callers handle it as any bad input
    assert peak < 50 * 2**20  # refused long before it grows (memory: a wall-clock bound fails on a loaded machine)


@PARSERS
def test_plain_yaml_reads_as_pyyaml_reads_it(c_parser):
    """The shipped configs and level files, and YAML's plain forms, give what yaml.safe_load gives."""
    files = [config_dir() / "default.yaml", config_dir() / "gait.yaml", *sorted((config_dir() / "levels").glob("*"))]
    assert len(files) > 10
    for path in files:
        text = path.read_text()
        assert parse(text, "f", c_parser=c_parser)[0] == yaml.safe_load(text), path
    text = "a: [1, 2.5, .inf, -3, 0x1f, 1_000, true, null, ~, '7', 2001-12-14]\n<<: {b: 1}\nc: {d: [e, f]}\n"
    assert parse(text, "f", c_parser=c_parser)[0] == yaml.safe_load(text)
    data, node = parse("a:\n  b: 1\n", "f", c_parser=c_parser)
    assert data == {"a": {"b": 1}} and node.value[0][1].value[0][0].start_mark.line == 1  # nodes carry lines


@PARSERS
def test_aliases_within_a_budget_and_named_tags_are_read_as_plain_data(c_parser):
    limits = Limits(aliases=2, tags=("!Arena", "!Vector3"))
    data = parse("p: &p !Vector3 {x: 1}\nq: [*p, *p]\nr: !Arena {t: 2}\n", "f", limits, c_parser)[0]
    assert data == {"p": {"x": 1}, "q": [{"x": 1}, {"x": 1}], "r": {"t": 2}}
    with pytest.raises(YAMLRefused, match=r"the tag !Item is not allowed; allowed: .*tags !Arena, !Vector3"):
        parse("a: !Item {}\n", "f", limits, c_parser)


def test_a_lone_surrogate_is_refused_by_name():
    with pytest.raises(YAMLRefused, match="line 1: a lone surrogate in a value"):
        parse('a: "\\ud800"\n', "f", c_parser=False)


def test_a_file_over_its_budget_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = tmp_path / "big.yaml"
    path.write_bytes(b"a: 1\n" + b"#" * (safe_yaml.MAX_BYTES))
    monkeypatch.setattr(safe_yaml, "parse", lambda *a, **k: pytest.fail("parsed"))
    with pytest.raises(
        YAMLRefused, match=rf"^level file '.*big.yaml' is {path.stat().st_size} bytes; allowed: at most"
    ):
        load(path, "level file")
    small = tmp_path / "small.yaml"
    small.write_text("a: [1, 2]\n")
    with pytest.raises(YAMLRefused, match="is 10 bytes; allowed: at most 5"):
        load(small, "file", Limits(max_bytes=5))


def test_not_utf8_a_missing_file_and_a_top_level_that_is_not_a_mapping(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(b"a: \xff\n")
    with pytest.raises(
        YAMLRefused, match=r"^gait file '.*bad.yaml' is not UTF-8 text \(invalid start byte at byte 3\)$"
    ):
        load(bad, "gait file")
    with pytest.raises(YAMLRefused, match=r"^gait file '.*none.yaml' does not exist$"):
        load(tmp_path / "none.yaml", "gait file")
    for endless in (Path("/dev/zero"), tmp_path):  # a device that never ends, a folder: never read
        with pytest.raises(YAMLRefused, match=r"^gait file '.*' is not a file$"):
            load(endless, "gait file")
    listed = tmp_path / "list.yaml"
    listed.write_text("- 1\n")
    with pytest.raises(YAMLRefused, match="the top level must be a mapping, got list"):
        load_mapping(listed, "gait file")
    empty = tmp_path / "empty.yaml"
    empty.write_text("# nothing\n")
    assert load_mapping(empty) == {}
