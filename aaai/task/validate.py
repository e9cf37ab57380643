"""Solvability checks under their older name: the one module is aaai.levels.validate, below the task.

``import aaai.task.validate`` gives that very module object (its tables, registries and any
patch a test makes are shared), so code written against the older name keeps working.
"""

import sys

from aaai.levels import validate
from aaai.levels.validate import *  # noqa: F403  (the names, for type checkers)

sys.modules[__name__] = validate
