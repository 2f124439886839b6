"""``agents.pure_pursuit``, kept for the code and documents that import it.

Pure pursuit and regulated pure pursuit; they live in :mod:`agents.controllers.pure_pursuit`.
"""

from agents.controllers.pure_pursuit import *  # noqa: F403
from agents.controllers.pure_pursuit import __all__ as __all__
