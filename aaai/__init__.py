"""Articulated Animal AI: a limbed agent finding food in seeded cognition test levels, on PyBullet.

Importing the package registers the Gymnasium ids (``aaai/AnimalAI-v0`` and one per level).
"""

import os
import sys


def _import_pybullet_quietly() -> None:
    """Imports pybullet with its build-time banner (printed by its C code to the process's
    stdout or stderr) sent to /dev/null, so that `import aaai` and the CLI print only what they
    mean to."""
    if "pybullet" in sys.modules:
        return
    try:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        saved, quiet = [os.dup(1), os.dup(2)], os.open(os.devnull, os.O_WRONLY)
    except (OSError, ValueError, AttributeError):  # no file descriptors to redirect: import as it is
        import pybullet  # noqa: F401

        return
    try:
        os.dup2(quiet, 1)
        os.dup2(quiet, 2)
        import pybullet  # noqa: F401
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for descriptor in (*saved, quiet):
            os.close(descriptor)


_import_pybullet_quietly()

from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.registration import register_envs  # noqa: E402

__version__ = "0.1.0"
__all__ = ["AnimalAIEnv", "register_envs"]

register_envs()
