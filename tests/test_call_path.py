"""The path a ``--policy`` takes from ``aaai eval`` to the episode loop stays short and goes one way.

The measure: ``aaai eval --policy reference`` runs through click's CliRunner on one episode of L0
(15 steps) with ``sys.setprofile`` on. From the moment the eval command's own function (found by its
click name, ``eval``, not by its file) is entered until the episode loop
(:func:`aaai.scoring.episodes.play`) is first entered, the calls of the package's Python functions
(files under ``aaai/`` and ``cli/``) are recorded. The stack chain that leads to the episode loop
(the eval command, each call still open below it, the loop itself; library frames such as click's
left out) is then read as a list of functions, and two numbers are taken from it:

- its calls: the functions in the chain, the eval command and the loop included (at most 15);
- its returns: how often the chain goes back into a module it had already left (``a -> b -> a``
  counts one), which is a module calling up into its caller's module again (at most 2).

Calls made and ended on the way (reading the config, resolving the policy) are not in the chain:
they return before the loop starts. The numbers are reported in the message when either is over.
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import yaml
from click.testing import CliRunner

import aaai
import aaai_cli
from aaai.scoring import episodes
from aaai_cli.main import cli

MAX_CALLS, MAX_RETURNS = 15, 2
ROOTS = tuple(str(Path(module.__file__).parent) for module in (aaai, aaai_cli))


def _ours(frame) -> bool:
    return frame.f_code.co_filename.startswith(ROOTS)


def _label(frame) -> str:
    return f"{frame.f_globals.get('__name__', '?')}.{frame.f_code.co_qualname}"


def eval_chain(tmp_path: Path) -> list[str]:
    """The chain of the package's functions from the eval command to the episode loop's first
    entry, each as ``module.function``."""
    command = inspect.unwrap(cli.commands["eval"].callback)
    start, loop = command.__code__, episodes.play.__code__
    found: list[str] = []
    entered = False

    def profile(frame, event, arg):
        nonlocal entered
        if event != "call" or found:
            return
        if frame.f_code is start:
            entered = True
        elif entered and frame.f_code is loop:
            chain, here = [], frame
            while here is not None:
                if _ours(here):
                    chain.append(_label(here))
                if here.f_code is start:
                    break
                here = here.f_back
            found.extend(reversed(chain))
            sys.setprofile(None)  # measured: the episode runs unprofiled

    config = tmp_path / "short.yaml"
    config.write_text(yaml.safe_dump({"episode": {"max_steps": 15}}))
    arguments = ["eval", "--policy", "reference", "--levels", "0", "--difficulty", "0", "-k", "1"]
    arguments += ["--seeds", "3", "--config", str(config), "--out", str(tmp_path / "board.csv")]
    sys.setprofile(profile)
    try:
        result = CliRunner().invoke(cli, arguments)
    finally:
        sys.setprofile(None)
    assert result.exit_code == 0, result.output
    assert found, "the episode loop was never entered from the eval command"
    return found


def returns(modules: list[str]) -> int:
    """How often a chain of modules goes back into a module it had left."""
    left: set[str] = set()
    count, previous = 0, None
    for name in modules:
        if name != previous:
            if name in left:
                count += 1
            if previous is not None:
                left.add(previous)
        previous = name
    return count


def _module(label: str) -> str:
    """``pkg.module.function`` (or ``pkg.module.Class.method``) -> its module's name."""
    name = label
    while name not in sys.modules and "." in name:
        name = name.rsplit(".", 1)[0]
    return name


def test_the_policy_reaches_the_episode_loop_in_a_few_calls_that_go_one_way(tmp_path):
    chain = eval_chain(tmp_path)
    modules = [_module(label) for label in chain]
    back = returns(modules)
    shown = " -> ".join(chain)
    assert chain[-1] == "aaai.scoring.episodes.play", shown
    assert len(chain) <= MAX_CALLS, f"{len(chain)} calls (at most {MAX_CALLS}): {shown}"
    assert back <= MAX_RETURNS, f"{back} returns to a module already left (at most {MAX_RETURNS}): {shown}"


def test_the_measure_counts_a_module_entered_again():
    assert returns(["a", "b", "a", "a", "c", "b"]) == 2
    assert returns(["a", "a", "b", "c"]) == 0
