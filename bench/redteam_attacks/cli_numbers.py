"""The cli-numbers group: negative, huge and NaN numbers given to flags."""

from __future__ import annotations

from .base import AAAI, ROOT, attack, train_argv

GROUP = "cli-numbers"


def attacks():
    fixtures = str(ROOT / "tests/fixtures/animalai")
    cases = {
        "steps-negative": train_argv("-1", "--run", "r"),
        "seed-2-64": [AAAI, "spec", "0", "-s", str(2**64)],
        "difficulty-huge": [AAAI, "spec", "0", "-d", "1000000000"],
        "show-seed-negative": [AAAI, "show", "0", "-s", "-5", "-o", "o.png"],
        "envs-zero": train_argv("10", "--envs", "0", "--run", "r"),
        "camera-resolution-huge": train_argv("10", "--camera", "--camera-resolution", "100000", "--run", "r"),
        "max-steps-negative": [AAAI, "run", "--max-steps", "-10"],
        "import-scale-nan": [AAAI, "import-animalai", fixtures, "--out", "o", "--scale", "nan"],
        "import-scale-zero": [AAAI, "import-animalai", fixtures, "--out", "o", "--scale", "0"],
        "run-max-steps-huge": [AAAI, "run", "--max-steps", str(10**30)],
    }
    for name, argv in cases.items():
        attack(f"cli-{name}", GROUP, argv, None, "error")
