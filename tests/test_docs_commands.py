"""Every shell command of the documentation (README.md and docs/**/*.md) as a user would type it.

The commands are those of the fenced code blocks: a ```bash block, or a plain block whose every line
is a command (`aaai`, `make`, `python`, ...); a trailing backslash continues a line, and a heredoc
(`<<'PY'`) runs to its end marker. A line with a placeholder (`RUN`, `FILE`, `[--json|--yaml]`,
`…`) is a synopsis, not a command to run.

- Fast (`make test`): every `aaai` command and option the docs name exists (in code blocks and in
  `aaai …` code spans of the text), every `make` target is in the Makefile, every `python -m`
  module is importable, and every relative link of a page leads to a file of the repository (as
  the repository's own pages resolve it).
- `make test-docs` (marked `docs_commands`, about 20 minutes): every command that is not a synopsis runs, page by page
  and in order, in a fresh copy of the repository's files with `.venv` active (the README's
  set-up), and must exit 0. `SMALLER` lists the commands run with a smaller budget than written
  and `SKIPPED` the ones not run, each with its reason.
  `make test-docs` runs it (about 20 minutes on 2 cores, `make demo` included).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]
STARTS = ("aaai ", "make ", "python ", "pip ", "for ", "source ", "tensorboard ", "MINARI_DATASETS_PATH=")

# Commands not run by the long test, by the start of their text, with the reason.
SKIPPED = {
    "make test": "the whole suite, this file among it",
    "pip install -e '.[play]'": "installs into the environment: the README's set-up (make test) has the play extra",
    "aaai play L1 -d 3 -s 7": "a server that runs until stopped (tests/test_play.py plays it in a browser)",
    "aaai play --seeds reserved": "a server that runs until stopped (tests/test_play.py plays it in a browser)",
    "tensorboard --logdir": "a server that runs until stopped",
    "caddy reverse-proxy": "a TLS proxy in front of a study server, needing a public name; one example of many",
    "make curricula": "about 25 minutes on 2 cores; the small version below runs",
    "aaai experiment curricula --config configs/curricula-300k.yaml": "about 11 hours (make curricula-300k)",
    "aaai experiment report experiments/curricula-300k": "needs the 300,000-decision runs (above, not run)",
    "aaai plot experiments/curricula-300k": "needs the 300,000-decision runs (above, not run)",
    "aaai train --config configs/student.yaml": "9 minutes of DAgger (make baselines-learned trains it)",
    "aaai eval --policy runs/student": "needs runs/student (above, not run) and 17 minutes of scoring",
    "aaai train --init-from runs/student": "needs runs/student (above, not run)",
    "aaai diagnose --policy runs/student": "needs runs/student (above, not run)",
    "aaai train --config configs/student_camera": "about 75 CPU minutes of DAgger each (tests/test_camera_student.py)",
    "aaai train --resume runs/student_camera": "needs runs/student_camera (above, not run)",
    "nice -n 10 .venv/bin/python bench/search_teacher.py": "about 1 CPU-hour: 3 x 1,430 episodes (small run: bench/)",
    "aaai train --config configs/student_search.yaml": "about half an hour of DAgger",
    "aaai train --config configs/student_search_sweep": "13 to 15 minutes of DAgger each (make students trains them)",
    "aaai train --config configs/student_food_memory.yaml": "22 minutes of DAgger (make students trains it)",
    "aaai train --config configs/student_food_memory_r12": "needs runs/student_food_memory (not run); 17 minutes",
    "aaai eval --policy runs/student_search": "needs runs/student_search (above, not run) and its scoring",
    "aaai eval --policy runs/reward_senses --checkpoints": "needs runs/reward_senses (an hour of training)",
    "aaai plot runs/reward_senses/curve.csv": "needs the curves of the runs above (not run)",
    "aaai import-animalai animal-ai/": "needs a clone of Animal-AI's repository in animal-ai/",
    "aaai eval --arenas /tmp/aai": "needs the arenas imported from Animal-AI's repository (above, not run)",
    "python -m aaai.tools.animalai /tmp/aai": "needs the arenas imported from Animal-AI's repository (above, not run)",
    "aaai baselines --battery /tmp/aai": "needs the arenas imported from Animal-AI's repository (above, not run)",
}

# Commands run with a smaller budget than written: (start of the command, written, run), with the reason.
SMALLER = [
    ("make demo", "make demo", "make -o .venv/.installed -o .venv/.installed-train demo", "the set-up is done"),
    ("aaai train --curriculum --run runs/demo", "--run runs/demo", "--run runs/demo --steps 2000", "make demo's run"),
    ("aaai train --curriculum --levels 0-11", "--steps 20000000", "--steps 1000", "hours of training"),
    ("aaai train --resume runs/big --steps", "--steps 40000000", "--steps 5000", "hours of training"),
    ("aaai train --config configs/reward_senses.yaml --minutes 60", "--steps 20000000", "--steps 1000", "an hour"),
    ("aaai experiment curricula --steps 20000", "--steps 20000", "--steps 1000", "minutes per run"),
    ("aaai experiment curricula --steps", "--out /tmp/small", "--out small", "a folder of this copy's own"),
    (
        "aaai train --init-from baselines/models/student.zip",
        "--run runs/student_ppo",
        "--run runs/student_ppo --steps 1024",
        "400,000 decisions of training",
    ),
    (
        "aaai eval --policy runs/student_ppo",
        "--seeds reserved",
        "--seeds reserved --levels 0 --difficulty 0 -k 2",
        "1,430 episodes",
    ),
    (
        "aaai demos --policy reference",
        "--levels all --difficulty 0-10 -k 5",
        "--levels 0 --difficulty 0",
        "715 episodes",
    ),
]


@dataclass(frozen=True)
class Command:
    page: str
    line: int
    text: str

    @property
    def synopsis(self) -> bool:
        """A line with placeholders: what a command looks like, not one to run."""
        head = self.text.split("\n")[0]
        code = re.sub(r"'[^']*'|\"[^\"]*\"", "''", re.sub(r"\s#.*$", "", head))
        if "[" in code or "…" in code or re.search(r"\S\|\S", code):
            return True
        return any(re.fullmatch(r"[A-Z]+(_[A-Z]+)*(:\d+)?", token) for token in code.split())

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.text.splitlines()[0]}"


def fenced_blocks(text: str):
    """(language, line of its first command, its lines) of each fenced code block."""
    lines = text.split("\n")
    index = 0
    while index < len(lines):
        opening = re.match(r"^(\s*)```(\w*)\s*$", lines[index])
        index += 1
        if not opening:
            continue
        indent, language, start, body = opening.group(1), opening.group(2), index, []
        while index < len(lines) and lines[index].strip() != "```":
            body.append(lines[index][len(indent) :])
            index += 1
        index += 1
        yield language, start + 1, body


def commands_of(page: Path) -> list[Command]:
    """The shell commands of a page's code blocks, in order."""
    found = []
    for language, first, body in fenced_blocks(page.read_text()):
        shell = language in ("bash", "sh", "shell", "console")
        if not shell and not (language == "" and body and all(line.startswith(STARTS) for line in body if line)):
            continue
        index = 0
        while index < len(body):
            line, number = body[index], first + index
            index += 1
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            text = [line]
            while text[-1].rstrip().endswith("\\") and index < len(body):
                text.append(body[index])
                index += 1
            heredoc = re.search(r"<<-?\s*'?(\w+)'?", line)
            if heredoc:
                while index < len(body):
                    text.append(body[index])
                    index += 1
                    if text[-1] == heredoc.group(1):
                        break
            found.append(Command(str(page.relative_to(ROOT)), number, "\n".join(text)))
    return found


def prose(page: Path) -> str:
    """A page's text with the lines of its fenced code blocks left empty (so lines keep their numbers)."""
    lines, inside = page.read_text().split("\n"), False
    for index, line in enumerate(lines):
        fence = line.strip().startswith("```")
        if fence or inside:
            lines[index] = ""
        if fence:
            inside = not inside
    return "\n".join(lines)


def inline_aaai(page: Path) -> list[Command]:
    """The `aaai …` code spans of a page's text (outside its code blocks)."""
    return [
        Command(str(page.relative_to(ROOT)), number, span)
        for number, line in enumerate(prose(page).split("\n"), 1)
        for span in re.findall(r"`(aaai [^`]+)`", line)
    ]


ALL = [c for page in PAGES for c in commands_of(page)]
INLINE = [c for page in PAGES for c in inline_aaai(page)]


def aaai_calls(text: str) -> list[list[str]]:
    """The words of each `aaai` call in a command (after `;`, `&&`, `do`, `$(`, or at its start)."""
    calls = []
    code = re.sub(r"\s#.*$", "", text.split("\n")[0].replace("\\", " "))
    for part in re.split(r";|&&|\|\||\$\(|\bdo\b|\bthen\b", code):
        words = part.split()
        if words and words[0] == "aaai":
            calls.append(words[1:])
    return calls


def check_aaai_call(words: list[str]) -> list[str]:
    """What of an `aaai` call does not exist: a command or an option ([], | and = read as notation)."""
    from aaai_cli.main import cli

    names = [words[0].split("/")] if words and not words[0].startswith("-") else [[]]
    problems = []
    for name in names[0] or [None]:
        command: click.Command = cli
        rest = ([name] if name else []) + words[1:]
        while isinstance(command, click.Group) and rest and not rest[0].startswith("-"):
            if re.fullmatch(r"[A-Z]+", rest[0]):  # `aaai COMMAND --help`
                return []
            sub = command.commands.get(rest[0])
            if sub is None:
                return [f"no command {rest[0]!r}"]
            command, rest = sub, rest[1:]
        known = {"--help"} | {o for p in command.params for o in (*p.opts, *p.secondary_opts)}
        for word in rest:
            for token in re.split(r"[|\[\]]", word):
                option = token.split("=")[0]
                if re.fullmatch(r"--?[A-Za-z][\w-]*", option) and option not in known:
                    problems.append(f"aaai {command.name}: no option {option}")
    return problems


def test_the_docs_have_commands_and_synopses_to_check():
    assert len(ALL) > 40 and len(INLINE) > 40
    assert any(c.synopsis for c in ALL) and sum(not c.synopsis for c in ALL) > 20
    texts = [c.text for c in ALL]
    assert "make demo" in " ".join(texts) and any("<<'PY'" in t and t.endswith("\nPY") for t in texts)


def test_every_documented_aaai_command_and_option_exists():
    problems = [f"{c}: {p}" for c in ALL + INLINE for words in aaai_calls(c.text) for p in check_aaai_call(words)]
    assert not problems, "\n".join(problems)


def test_every_documented_make_target_and_python_module_exists():
    import importlib.util

    targets = set(re.findall(r"^([\w-]+):", (ROOT / "Makefile").read_text(), flags=re.M))
    problems = []
    for command in ALL:
        code = re.sub(r"\s#.*$", "", command.text.split("\n")[0])
        for target in re.findall(r"(?:^|[;&]\s*)make ((?:[\w-]+ ?)+)", code):
            problems += [f"{command}: no make target {t}" for t in target.split() if t not in targets]
        for module in re.findall(r"python -m ([\w.]+)", command.text):
            if importlib.util.find_spec(module) is None:
                problems.append(f"{command}: no module {module}")
    assert not problems, "\n".join(problems)


def test_every_skip_and_smaller_budget_names_a_documented_command():
    runnable = [c.text for c in ALL if not c.synopsis]
    stale = [start for start in SKIPPED if not any(t.startswith(start) for t in runnable)]
    stale += [
        start for start, written, _, _ in SMALLER if not any(t.startswith(start) and written in t for t in runnable)
    ]
    assert not stale, f"no documented command starts so any more: {stale}"


def test_every_relative_link_of_a_page_leads_to_a_file_of_the_repository():
    broken = []
    for page in PAGES:
        text = re.sub(r"`[^`\n]*`", "", prose(page))
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            if not (page.parent / target.split("#")[0]).exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, "\n".join(broken)


def run_as_documented(command: Command) -> str:
    """The command's text as the long test runs it (a smaller budget where SMALLER says)."""
    text = command.text
    for start, written, smaller, _ in SMALLER:
        if text.startswith(start):
            text = text.replace(written, smaller, 1)
    return text


def fresh_copy(folder: Path) -> Path:
    """The repository's files (as a clone has them) in ``folder``, with this checkout's `.venv`."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, files.decode().split("\0")):
        source = ROOT / name
        if source.is_file():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, folder / name)
    (folder / ".venv").symlink_to(ROOT / ".venv")
    return folder


@pytest.mark.docs_commands
@pytest.mark.parametrize("page", sorted({c.page for c in ALL if not c.synopsis}))
def test_every_documented_command_runs_on_a_fresh_copy(page, tmp_path):
    copy = fresh_copy(tmp_path / "aaai")
    bin_dir = str(copy / ".venv" / "bin")
    env = {**os.environ, "PATH": bin_dir + os.pathsep + os.environ["PATH"], "VIRTUAL_ENV": str(copy / ".venv")}
    env.pop("PYTHONPATH", None)
    failed = []
    for command in [c for c in ALL if c.page == page and not c.synopsis]:
        if any(command.text.startswith(start) for start in SKIPPED):
            continue
        done = subprocess.run(
            ["bash", "-c", run_as_documented(command)], cwd=copy, env=env, capture_output=True, text=True, timeout=1800
        )
        if done.returncode != 0:
            tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-8:])
            failed.append(f"{command} (exit {done.returncode}; ran {shlex.quote(run_as_documented(command))})\n{tail}")
    assert not failed, "\n\n".join(failed)
