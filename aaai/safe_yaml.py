"""YAML from outside read as plain data, within limits of size, nesting, aliases, tags and numbers.

Every YAML file the package reads from a user (configs, arena files, level files, the gait file,
a run's config, Animal-AI arena files) goes through :func:`load`. The file is refused, with one
message naming it, the line and what is allowed (:class:`YAMLRefused`, a ``ConfigError``):

- over its size budget (``Limits.max_bytes``), before it is parsed; not UTF-8; holding a NUL or
  another control character;
- nesting deeper than ``Limits.max_depth`` lists and mappings;
- using an alias (``*name``) where none are allowed, more aliases than its budget, an alias to a
  value that holds it, or aliases that would expand past ``Limits.max_values`` values (a "billion
  laughs" file): counted while the file is composed, before any Python object is built;
- a tag other than YAML's plain ones (null, bool, int, float, str, seq, map, timestamp) and the
  local tags the caller names (Animal-AI's ``!Arena``...): no ``!!python/...``, nothing is run;
- a key that is a list or a mapping; a NUL character or a lone surrogate in a value (``"\\0"``);
- an integer of more than MAX_DIGITS digits, a number too large for a float (``1e999``), a date
  that does not exist.

Events come from libyaml's parser when PyYAML has it (``yaml._yaml.CParser``), else from PyYAML's
own; the composing, counting and checking are the same Python code for both.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import SafeConstructor
from yaml.events import (
    AliasEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
    StreamEndEvent,
)
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.parser import Parser
from yaml.reader import Reader
from yaml.resolver import Resolver
from yaml.scanner import Scanner

from aaai.errors import ConfigError

_CParser: type[CParser] | None  # libyaml's parser: the same events, faster
try:
    from yaml._yaml import CParser

    _CParser = CParser
except ImportError:  # pragma: no cover - PyYAML built without libyaml
    _CParser = None

MAX_BYTES = 1 << 20  # a config, arena or level file is a few kB; anything near a megabyte is a mistake
MAX_DEPTH = 20
MAX_VALUES = 1_000_000  # values (scalars, lists, mappings) once aliases are expanded
MAX_DIGITS = 40  # an integer's digits: far beyond any count or seed, short of what a float cannot hold
YAML_TAG = "tag:yaml.org,2002:"
PLAIN_TAGS = tuple(
    YAML_TAG + name for name in ("null", "bool", "int", "float", "str", "seq", "map", "timestamp", "merge", "value")
)
_KIND_TAG = {ScalarNode: YAML_TAG + "str", SequenceNode: YAML_TAG + "seq", MappingNode: YAML_TAG + "map"}
# YAML's printable characters (YAML 1.1, 5.1): anything else (NUL, other controls) is refused
_NOT_PRINTABLE = re.compile("[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
_NOT_IN_VALUE = re.compile("[\x00\ud800-\udfff]")  # a NUL or a lone surrogate written as an escape


@dataclass(frozen=True)
class Limits:
    """What a file may hold. The defaults are a config file's: no aliases at all."""

    max_bytes: int = MAX_BYTES
    max_depth: int = MAX_DEPTH
    aliases: int = 0  # how many aliases (*name) a file may use
    max_values: int = MAX_VALUES  # values once every alias is expanded
    tags: tuple[str, ...] = ()  # local tags (e.g. "!Arena") read as the plain mapping, list or text they tag


class YAMLRefused(ConfigError):
    """A YAML file outside the limits or not YAML: ``str()`` names the file; ``detail`` is the
    problem without the file's name (``line 3: ...; allowed: ...``) and ``line`` its line (or None)."""

    def __init__(self, message: str, detail: str, line: int | None = None):
        super().__init__(message)
        self.detail, self.line = detail, line


class _Refusal(Exception):
    """A problem at a place in the text, before the file's name is put in front of it."""

    def __init__(self, mark: Any, problem: str, syntax: bool = False):
        super().__init__(problem)
        self.line = mark.line + 1 if mark is not None else None
        self.column = mark.column + 1 if mark is not None else None
        self.problem, self.syntax = problem, syntax


def _short(text: str, size: int = 40) -> str:
    return text if len(text) <= size else text[: size - 3] + "..."


class _Composer:
    """Nodes from parser events, counting as it goes: depth, aliases and values are refused at the
    event that passes the limit, so nothing beyond it is ever built."""

    def __init__(self, parser: Any, limits: Limits):
        self.parser, self.limits = parser, limits
        self.resolver = Resolver()
        self.anchors: dict[str, tuple[Node, int, int]] = {}  # anchor -> (node, values, height)
        self.open: set[str] = set()  # anchors whose node is still being composed
        self.aliases = 0
        self.values = 0

    def document(self) -> Node | None:
        parser = self.parser
        parser.get_event()  # the stream's start
        if parser.check_event(StreamEndEvent):
            return None
        parser.get_event()  # the document's start
        node = self.node(0)[0]
        parser.get_event()  # the document's end
        if not parser.check_event(StreamEndEvent):
            raise _Refusal(parser.peek_event().start_mark, "a second document (---); allowed: one document")
        return node

    def count(self, values: int, mark: Any) -> None:
        self.values += values
        if self.values > self.limits.max_values:
            raise _Refusal(
                mark,
                f"the file holds more than {self.limits.max_values:,} values once its aliases are expanded; "
                f"allowed: at most {self.limits.max_values:,}",
            )

    def deep(self, depth: int, mark: Any) -> None:
        if depth > self.limits.max_depth:
            raise _Refusal(mark, "nests too deeply")

    def tag(self, event: Any, kind: type) -> str:
        tag = event.tag
        if tag is None or tag == "!":
            if kind is ScalarNode:
                return self.resolver.resolve(ScalarNode, event.value, event.implicit)
            return self.resolver.resolve(kind, None, event.implicit)
        if tag in PLAIN_TAGS:
            return tag
        if tag in self.limits.tags:
            return _KIND_TAG[kind]
        shown = "!!" + tag[len(YAML_TAG) :] if tag.startswith(YAML_TAG) else tag
        allowed = "plain YAML without tags" + (
            f", and the tags {', '.join(self.limits.tags)}" if self.limits.tags else ""
        )
        raise _Refusal(event.start_mark, f"the tag {_short(shown)} is not allowed; allowed: {allowed}")

    def node(self, depth: int) -> tuple[Node, int, int]:
        """The next node, the values it stands for (aliases expanded) and its height."""
        event = self.parser.get_event()
        mark = event.start_mark
        if isinstance(event, AliasEvent):
            if not self.limits.aliases:
                raise _Refusal(
                    mark,
                    "an alias (*name) is not allowed here; allowed: plain values, each written out where it is used",
                )
            self.aliases += 1
            if self.aliases > self.limits.aliases:
                raise _Refusal(
                    mark, f"more than {self.limits.aliases} aliases (*name); allowed: at most {self.limits.aliases}"
                )
            name = event.anchor
            assert name is not None  # an alias (*name) always names its anchor
            if name in self.open:
                raise _Refusal(
                    mark,
                    f"the alias *{_short(name)} is inside the value it names; "
                    "allowed: an alias to a value written before it",
                )
            if name not in self.anchors:
                raise _Refusal(mark, f"the alias *{_short(name)} names no anchor (&name) before it", syntax=True)
            target, values, height = self.anchors[name]
            self.count(values, mark)
            self.deep(depth + height, mark)
            return target, values, height
        anchor = event.anchor
        node: Node
        if isinstance(event, ScalarEvent):
            bad = _NOT_IN_VALUE.search(event.value)
            if bad:
                what = "a NUL character" if bad.group() == "\0" else "a lone surrogate"
                raise _Refusal(mark, f"{what} in a value; allowed: text without NUL characters or lone surrogates")
            self.count(1, mark)
            # libyaml's events carry its own marks (yaml._yaml.Mark), which the PyYAML stubs' nodes do not name
            end_mark = event.end_mark
            node = ScalarNode(self.tag(event, ScalarNode), event.value, mark, end_mark, style=event.style)  # type: ignore[arg-type]
            values, height = 1, 0
        elif isinstance(event, (SequenceStartEvent, MappingStartEvent)):
            self.deep(depth + 1, mark)
            self.count(1, mark)
            mapping = isinstance(event, MappingStartEvent)
            kind = MappingNode if mapping else SequenceNode
            node = kind(self.tag(event, kind), [], mark, None, flow_style=event.flow_style)
            if anchor is not None:
                self.open.add(anchor)
            values, height = 1, 0
            end = MappingEndEvent if mapping else SequenceEndEvent
            while not self.parser.check_event(end):
                child, child_values, child_height = self.node(depth + 1)
                if mapping:
                    if not isinstance(child, ScalarNode):
                        raise _Refusal(
                            child.start_mark,
                            f"a key that is a {'mapping' if isinstance(child, MappingNode) else 'list'}; "
                            "allowed: keys that are text or numbers",
                        )
                    value, value_values, value_height = self.node(depth + 1)
                    node.value.append((child, value))
                    child_values += value_values
                    child_height = max(child_height, value_height)
                else:
                    node.value.append(child)
                values += child_values
                height = max(height, child_height)
            node.end_mark = self.parser.get_event().end_mark
            height += 1
            self.open.discard(anchor)
        else:  # pragma: no cover - the parser gives no other event here
            raise _Refusal(mark, f"unexpected {type(event).__name__}", syntax=True)
        if anchor is not None:
            self.anchors[anchor] = (node, values, height)
        return node, values, height


class _Constructor(SafeConstructor):
    """PyYAML's safe constructor with numbers checked: no integer of thousands of digits, no float
    that overflows, no date that does not exist; each refused at its line."""

    def construct_object(self, node: Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep)
        except (ValueError, OverflowError) as error:
            text = _short(str(node.value)) if isinstance(node, ScalarNode) else node.tag
            raise _Refusal(
                node.start_mark, f"{text!r} cannot be read as {node.tag.rsplit(':', 1)[-1]} ({error})"
            ) from None

    def construct_checked_int(self, node: ScalarNode) -> int:
        text = str(node.value).replace("_", "").lstrip("+-")
        if len(text) > MAX_DIGITS:
            raise _Refusal(
                node.start_mark,
                f"an integer of {len(text):,} digits ({_short(str(node.value), 20)}); allowed: at most {MAX_DIGITS}",
            )
        return self.construct_yaml_int(node)

    def construct_checked_float(self, node: ScalarNode) -> float:
        value = self.construct_yaml_float(node)
        if math.isinf(value) and "inf" not in str(node.value).lower():
            raise _Refusal(
                node.start_mark,
                f"the number {_short(str(node.value), 20)} is too large for a float; allowed: numbers up to about "
                "1.8e308 in size (or .inf written as such)",
            )
        return value

    def construct_value(self, node: ScalarNode) -> str:
        return self.construct_scalar(node)

    yaml_constructors = {  # the safe ones, with numbers checked (as add_constructor would set them)
        **SafeConstructor.yaml_constructors,
        YAML_TAG + "int": construct_checked_int,
        YAML_TAG + "float": construct_checked_float,
        YAML_TAG + "value": construct_value,
    }


class _PyParser(Reader, Scanner, Parser):
    """PyYAML's own reader, scanner and parser: events only, nothing constructed."""

    def __init__(self, text: str):
        Reader.__init__(self, text)
        Scanner.__init__(self)
        Parser.__init__(self)


def parse(text: str, label: str, limits: Limits = Limits(), c_parser: bool = True) -> tuple[Any, Node | None]:
    """The plain data a YAML text holds and its node tree (each node with its line); a refusal is a
    YAMLRefused naming ``label`` (e.g. ``"arena file 'x.yaml'"``)."""

    def refused(detail: str, line: int | None = None, syntax: bool = False) -> YAMLRefused:
        return YAMLRefused(f"{label} {'is not valid YAML: ' if syntax else ''}{detail}", detail, line)

    bad = _NOT_PRINTABLE.search(text)
    if bad:
        line = text.count("\n", 0, bad.start()) + 1
        raise refused(
            f"line {line}: the character U+{ord(bad.group()):04X} is not allowed; allowed: printable text "
            "(no NUL or other control characters)",
            line,
        )
    try:
        parser = _CParser(text) if c_parser and _CParser is not None else _PyParser(text)
        try:
            node = _Composer(parser, limits).document()
        finally:
            if hasattr(parser, "dispose"):
                parser.dispose()
        data = _Constructor().construct_document(node) if node is not None else None
    except _Refusal as refusal:
        if refusal.problem == "nests too deeply":
            raise refused(
                f"nests too deeply at line {refusal.line}; allowed: {limits.max_depth} levels", refusal.line
            ) from None
        place = f"line {refusal.line}, column {refusal.column}" if refusal.syntax else f"line {refusal.line}"
        raise refused(f"{place}: {refusal.problem}", refusal.line, refusal.syntax) from None
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        if mark is not None and "nesting depth" in str(error.problem):  # libyaml's own limit (1000), far above ours
            line = mark.line + 1
            raise refused(f"nests too deeply at line {line}; allowed: {limits.max_depth} levels", line) from None
        problem = error.problem or error.context or "not YAML"
        if error.context and error.problem:
            problem += f" ({error.context})"
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        raise refused(f"{where}{problem}", mark.line + 1 if mark is not None else None, syntax=True) from None
    except yaml.YAMLError as error:
        raise refused(" ".join(str(error).split()), syntax=True) from None
    return data, node


def load_with_nodes(path: str | Path, what: str = "file", limits: Limits = Limits()) -> tuple[Any, Node | None]:
    """A YAML file's plain data and node tree, read within ``limits``; errors name the file as
    ``what`` (``"config file"``) and its path."""
    path = Path(path)
    label = f"{what} {str(path)!r}"
    if not path.is_file():
        if path.exists():  # a folder, a device, a pipe: nothing to read as a file (and /dev/zero never ends)
            raise YAMLRefused(f"{label} is not a file", "not a file")
        raise YAMLRefused(f"{label} does not exist", "does not exist")
    size = path.stat().st_size
    if size > limits.max_bytes:
        detail = f"{size:,} bytes; allowed: at most {limits.max_bytes:,}"
        raise YAMLRefused(f"{label} is {size} bytes; allowed: at most {limits.max_bytes}", detail)
    with path.open("rb") as handle:
        raw = handle.read(limits.max_bytes + 1)  # the file may have grown since it was measured
    if len(raw) > limits.max_bytes:
        raise YAMLRefused(f"{label} is over {limits.max_bytes} bytes", f"over {limits.max_bytes:,} bytes")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        detail = f"not UTF-8 text ({error.reason} at byte {error.start})"
        raise YAMLRefused(f"{label} is {detail}", detail) from None
    return parse(text, label, limits)


def load(path: str | Path, what: str = "file", limits: Limits = Limits()) -> Any:
    """A YAML file's plain data, read within ``limits`` (see :func:`load_with_nodes`)."""
    return load_with_nodes(path, what, limits)[0]


def load_mapping(path: str | Path, what: str = "file", limits: Limits = Limits()) -> dict:
    """A YAML file whose top level is a mapping (an empty file: ``{}``)."""
    data = load(path, what, limits)
    if data is None:
        return {}
    if not isinstance(data, dict):
        message = f"{what} {str(Path(path))!r}: the top level must be a mapping, got {type(data).__name__}"
        raise YAMLRefused(message, f"the top level must be a mapping, got {type(data).__name__}", 1)
    return data
