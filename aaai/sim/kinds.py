"""The object kinds under their older name: the one module is aaai.spec.kinds, below the simulation.

``import aaai.sim.kinds`` gives that very module object (its tables, registries and any
patch a test makes are shared), so code written against the older name keeps working.
"""

import sys

from aaai.spec import kinds
from aaai.spec.kinds import *  # noqa: F403  (the names, for type checkers)

sys.modules[__name__] = kinds
