"""The moving parts under their older name: the one module is aaai.spec.behaviours, below the simulation.

``import aaai.sim.behaviours`` gives that very module object (its tables, registries and any
patch a test makes are shared), so code written against the older name keeps working.
"""

import sys

from aaai.spec import behaviours
from aaai.spec.behaviours import *  # noqa: F403  (the names, for type checkers)

sys.modules[__name__] = behaviours
