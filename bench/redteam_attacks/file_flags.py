"""The file-flags group: each flag that takes a file given a folder, a pipe, a device, a broken link,
a link loop or binary bytes; good files under odd names; outputs that cannot be written."""

from __future__ import annotations

from .base import AAAI, ARENA, SHORT_YAML, attack, base, eval_argv
from .inputs import fifo, folder, link, text

GROUP = "file-flags"

FILE_KINDS = {
    "dir": lambda n: folder(n),
    "fifo": lambda n: fifo(n),
    "devzero": lambda n: link(n, "/dev/zero"),
    "broken-link": lambda n: link(n, "{W}/nowhere"),
    "link-loop": lambda n: link(n, "{W}/" + n),
    "binary": lambda n: text(n, bytes(range(256)) * 64),
}


def flags():
    """Each flag's command line (``F`` where the file goes) and the file's extension."""
    short = str(base() / "short.yaml")
    return {
        "run-config": ([AAAI, "run", "--levels", "0", "--max-steps", "10", "--config", "F"], ".yaml"),
        "run-arena": ([AAAI, "run", "--max-steps", "10", "--arena", "F"], ".yaml"),
        "show-arena": ([AAAI, "show", "--arena", "F", "-o", "o.png"], ".yaml"),
        "eval-seed-key": (
            [AAAI, "eval", "--policy", "random", "--levels", "0", "-k", "1", "--config", short]
            + ["--seed-key-file", "F", "--out", "s.csv"],
            ".key",
        ),
        "seeds-seed-key": ([AAAI, "seeds", "--levels", "0", "--difficulty", "0", "--seed-key-file", "F"], ".key"),
        "eval-policy-zip": (eval_argv(policy="F", k="1"), ".zip"),
        "eval-arenas": (
            [AAAI, "eval", "--policy", "random", "--arenas", "F", "-k", "1", "--config", short, "--out", "s.csv"],
            ".yaml",
        ),
        "validate-arena": ([AAAI, "validate", "--arena", "F"], ".yaml"),
        "train-init-from": (
            [AAAI, "train", "--steps", "64", "--run", "r", "--init-from", "F", "--config", short],
            ".zip",
        ),
        "import-source": ([AAAI, "import-animalai", "F", "--out", "out"], ".yaml"),
        "plot-run": ([AAAI, "plot", "F", "--out", "p.png"], ""),
    }


def attacks():
    for flag, (argv, ext) in flags().items():
        for kind, make in FILE_KINDS.items():
            if kind == "dir" and flag in ("eval-arenas", "validate-arena", "plot-run", "import-source"):
                continue  # a folder is allowed there
            name = "F" + ext
            attack(
                f"file-{flag}-{kind}", GROUP, [name if a == "F" else a for a in argv], make(name), "error", timeout=30
            )
    # unicode and odd names holding good content: must work
    odd = {"unicode": "конфиг ü.yaml", "newline": "a\nb.yaml", "dash": "-c.yaml", "rtl": "a\u202eLMAY.yaml"}
    for kind, name in odd.items():
        argv = [AAAI, "run", "--levels", "0", "--max-steps", "10", "--no-camera", "--config", "./" + name]
        attack(f"file-run-config-name-{kind}", GROUP, argv, text(name, SHORT_YAML), "ok")
        argv = [AAAI, "run", "--max-steps", "10", "--no-camera", "--arena", "./" + name]
        attack(f"file-run-arena-name-{kind}", GROUP, argv, text(name, ARENA), "ok")
    show = [AAAI, "show", "0", "-o"]
    attack("file-show-output-dir", GROUP, show + ["o.png"], folder("o.png"), "error")
    attack("file-show-output-fifo", GROUP, show + ["o.png"], fifo("o.png"), "any", timeout=30)
    attack("file-show-output-dev-full", GROUP, show + ["/dev/full"], None, "error")
    attack("file-show-video-odd-ext", GROUP, [AAAI, "show", "0", "--video", "v.exe", "--steps", "5"], None, "error")
    attack("file-show-output-missing-dir", GROUP, show + ["no/such/o.png"], None, "any")
    attack("file-eval-out-dev-full", GROUP, eval_argv("/dev/full", k="1"), None, "error")
    attack("file-eval-out-dir", GROUP, eval_argv(k="1"), folder("s.csv"), "error")
    attack("file-eval-out-fifo", GROUP, eval_argv(k="1"), fifo("s.csv"), "error", timeout=30)
    replays_file = eval_argv(k="1", extra=["--save-replays", "rp"])
    attack("file-eval-save-replays-file", GROUP, replays_file, text("rp", "x"), "error")
