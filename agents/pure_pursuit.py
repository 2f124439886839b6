"""``agents.pure_pursuit``, kept for the code and documents that import it.

Pure pursuit and regulated pure pursuit; they live in :mod:`agents.controllers.pure_pursuit`.
"""

from agents.controllers.pure_pursuit import (
    MODES,
    ForwardProjection,
    Point,
    PurePursuit,
    RegulatedPurePursuit,
)

__all__ = [
    "MODES",
    "ForwardProjection",
    "Point",
    "PurePursuit",
    "RegulatedPurePursuit",
]
