"""Seed ranges under their older name: the one module is aaai.levels.seeds, below the task.

``import aaai.task.seeds`` gives that very module object (its tables, registries and any
patch a test makes are shared), so code written against the older name keeps working.
"""

import sys

from aaai.levels import seeds
from aaai.levels.seeds import *  # noqa: F403  (the names, for type checkers)

sys.modules[__name__] = seeds
