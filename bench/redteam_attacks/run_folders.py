"""The run-folders group: ``train --resume`` of a run folder whose files link outside, are pipes or
hold odd data; ``eval --out`` whose lock, summary or replays link outside; odd run names."""

from __future__ import annotations

import os

from .base import AAAI, ROOT, attack, base, eval_argv, train_argv
from .inputs import both, copy, link, text, unchanged, victim

GROUP = "run-folders"
RESUME = [AAAI, "train", "--steps", "300", "--resume", "run"]


def in_run(*makers):
    """A copy of the shared run folder as ``run``, then ``makers``."""
    return both(copy("run", "run"), *makers)


def swapped(name, put):
    """The run's file ``name`` taken out and ``put`` in its place (``put`` makes it at the path)."""

    def make(w):
        (w / "run" / name).unlink()
        put(w / "run" / name)

    return make


def to_victim(path):
    """A link at ``path`` (in the work folder's ``run``) to the outside victim."""
    os.symlink(path.parents[2] / "outside" / "victim.txt", path)


def staging_out(w):
    (w.parent / "outside" / "keep").mkdir()
    (w.parent / "outside" / "keep" / "victim.txt").write_text("x\n")


def kept(w, r):
    return None if (w.parent / "outside" / "keep" / "victim.txt").is_file() else "outside file removed"


def states(change):
    """Every ``state.json`` of the run rewritten by ``change`` (its text to the new text)."""
    return lambda w: [p.write_text(change(p.read_text())) for p in (w / "run").rglob("state.json")]


def replays_linked_out(w):
    (w / "rp").mkdir()
    for p in (base() / "rep").glob("*.json"):
        os.symlink(w.parent / "outside" / "victim.txt", w / "rp" / p.name)


def attacks():
    mkfifo = os.mkfifo
    attack(
        "runs-resume-episodes-symlink-out",
        GROUP,
        RESUME,
        in_run(victim(), swapped("episodes.csv", to_victim)),
        "any",
        check=unchanged(),
    )
    attack(
        "runs-resume-lock-symlink-out",
        GROUP,
        RESUME,
        in_run(victim(), link("run/.lock", "{O}/victim.txt")),
        "any",
        check=unchanged(),
    )
    etc_passwd = swapped("config.yaml", lambda p: os.symlink("/etc/passwd", p))
    attack("runs-resume-config-etc-passwd", GROUP, RESUME, in_run(etc_passwd), "error")
    attack("runs-resume-config-fifo", GROUP, RESUME, in_run(swapped("config.yaml", mkfifo)), "error", timeout=30)
    staging = in_run(staging_out, link("run/checkpoints/.staging-evil", "{O}/keep"))
    attack("runs-resume-staging-symlink-out", GROUP, RESUME, staging, "any", check=kept)
    attack("runs-resume-state-json-deep", GROUP, RESUME, in_run(states(lambda s: "[" * 100000)), "error")
    attack("runs-resume-state-json-nan", GROUP, RESUME, in_run(states(lambda s: s.replace("0", "NaN", 3))), "any")
    attack("runs-resume-episodes-fifo", GROUP, RESUME, in_run(swapped("episodes.csv", mkfifo)), "error", timeout=30)
    binary = in_run(text("run/episodes.csv", bytes(range(256)) * 10))
    attack("runs-resume-episodes-binary", GROUP, RESUME, binary, "any")
    attack("runs-run-is-file", GROUP, train_argv("50", "--run", "r"), text("r", "x"), "error")
    unicode_run = train_argv("50", "--config", str(base() / "short.yaml"), "--run", "прогон ü")
    attack("runs-run-unicode", GROUP, unicode_run, None, "ok")
    to_file = both(victim(), link("r", "{O}/victim.txt"))
    attack("runs-run-symlink-to-file-out", GROUP, train_argv("50", "--run", "r"), to_file, "error", check=unchanged())
    for name, linked in [("lock", ".s.csv.lock"), ("summary", "s_summary.md")]:
        setup = both(victim(), link(linked, "{O}/victim.txt"))
        attack(f"runs-eval-{name}-symlink-out", GROUP, eval_argv(), setup, "any", check=unchanged())
    replays = eval_argv(extra=["--save-replays", "rp"])
    setup = both(victim(), replays_linked_out)
    attack("runs-eval-replay-name-symlink-out", GROUP, replays, setup, "ok", check=unchanged())
    plot = [AAAI, "plot", "run", "--out", "p.png"]
    attack("runs-plot-episodes-fifo", GROUP, plot, in_run(swapped("episodes.csv", mkfifo)), "any", timeout=30)
    import_out = [AAAI, "import-animalai", str(ROOT / "tests/fixtures/animalai"), "--out", "o"]
    attack("runs-import-out-is-file", GROUP, import_out, text("o", "x"), "error")
