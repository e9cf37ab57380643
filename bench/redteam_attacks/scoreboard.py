"""The scoreboard group: ``eval --out`` resuming a scoreboard torn, reordered, in another encoding,
of odd rows or another tool's."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from .base import Result, attack, base, eval_argv
from .inputs import board_file


def lines(f):
    """The scoreboard's bytes as its lines, changed by ``f`` (lines to text)."""
    return lambda raw: f(raw.decode().splitlines(keepends=True)).encode()


def first_row(f):
    """The scoreboard with its first row changed by ``f`` (the row's text to the new text)."""
    return lines(lambda ls: ls[0] + f(ls[1]) + "".join(ls[2:]))


def attacks():
    cases = {
        "torn-header": lambda raw: raw[:20],
        "header-only": lambda raw: raw.split(b"\n")[0] + b"\n",
        "columns-reordered": lines(lambda ls: ",".join(reversed(ls[0].strip().split(","))) + "\n" + "".join(ls[1:])),
        "extra-column": lines(lambda ls: ls[0].strip() + ",evil\n" + "".join(x.strip() + ",1\n" for x in ls[1:])),
        "missing-column": lines(lambda ls: "".join(",".join(x.strip().split(",")[1:]) + "\n" for x in ls)),
        "return-nan": first_row(lambda row: row.replace(row.split(",")[4], "nan", 1)),
        "seed-foreign": first_row(lambda row: row.replace(row.split(",")[3], "12345", 1)),
        "duplicate-rows": first_row(lambda row: row + row),
        "crlf": lambda raw: raw.replace(b"\n", b"\r\n"),
        "bom": lambda raw: b"\xef\xbb\xbf" + raw,
        "nul-middle": lambda raw: raw[:60] + b"\x00" * 10 + raw[60:],
        "binary": lambda raw: bytes(range(256)) * 8,
        "empty": lambda raw: b"",
        "newline-only": lambda raw: b"\n",
        "thousand-columns": lines(lambda ls: ls[0] + ls[1].strip() + ",x" * 1000 + "\n"),
        "long-line": lines(lambda ls: ls[0] + "0," + "9" * 5_000_000 + "\n"),
        "unbalanced-quote": lines(lambda ls: ls[0] + '"' + ls[1]),
        "other-tool-header": lambda raw: b"a,b,c\n1,2,3\n",
        "utf16": lambda raw: raw.decode().encode("utf-16"),
        "latin1-name": lambda raw: raw.replace(b"food_contact", b"f\xe9od"),
        "level-99": first_row(lambda row: "99" + row[1:]),
        "steps-negative": first_row(lambda row: row.replace(",20,20,", ",-20,20,", 1)),
        "arena-traversal": first_row(lambda row: row.replace(",False,,", ",False,../../../etc/passwd,", 1)),
        "row-of-commas": lines(lambda ls: ls[0] + "," * 14 + "\n"),
    }
    for name, change in cases.items():
        attack(f"board-{name}", "scoreboard", eval_argv(), board_file("s.csv", change), "any", check=board_check)


def board_check(w: Path, r: Result) -> str | None:
    if r.code == 0:  # every planned episode is there once (a row a user added by hand is kept as it is)
        rows = list(csv.DictReader(io.StringIO((w / "s.csv").read_text(errors="replace"))))
        base_rows = list(csv.DictReader((base() / "board.csv").open()))
        planned = {(x["level"], x["difficulty"], x["seed"]) for x in base_rows}
        got = [(x.get("level"), x.get("difficulty"), x.get("seed")) for x in rows]
        if not planned <= set(got):
            return f"the resumed scoreboard lacks {len(planned - set(got))} planned episodes"
    return None
