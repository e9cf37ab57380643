"""The core tests on the oldest and the newest Gymnasium that setup.cfg allows (``make test-gym``).

Each version gets a small venv of its own under ``.nox/`` (the package, its ``dev`` and ``train``
extras, no Ray, whose ``rllib`` extra pins one Gymnasium): the environment, the scoring, the model
loading and the committed models are tested there. ``nox -s "gym(gymnasium='1.4.0')"`` runs one.
"""

from __future__ import annotations

import os

import nox

# The bounds of setup.cfg's gymnasium requirement: the oldest allowed and the newest tested.
GYMNASIUM = ("1.1.0", "1.4.0")
# torch first, the CPU build (as the Makefile's TORCH_SPEC): a bare requirement pulls a multi-GB CUDA build.
TORCH_SPEC = os.environ.get("TORCH_SPEC", "torch==2.13.0")
CORE_TESTS = (
    "tests/test_env.py",
    "tests/test_scoring.py",
    "tests/test_policies.py",
    "tests/test_trust.py",
    "tests/test_portable_models.py",
)

nox.options.default_venv_backend = "venv"
nox.options.reuse_existing_virtualenvs = True
nox.options.sessions = ["gym"]


@nox.session
@nox.parametrize("gymnasium", GYMNASIUM)
def gym(session: nox.Session, gymnasium: str) -> None:
    session.install("--quiet", TORCH_SPEC)
    session.install("--quiet", "-e", ".[dev,train]", f"gymnasium=={gymnasium}")
    session.run("python", "-c", "import gymnasium; print('gymnasium', gymnasium.__version__)")
    # CI= : the tests of extras this venv lacks (Ray) are skipped here, not failed (tests/conftest.py, needs)
    session.run("python", "-m", "pytest", "-q", "-m", "not long", "-p", "no:cacheprovider", *CORE_TESTS, env={"CI": ""})
