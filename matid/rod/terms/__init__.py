"""The loads on the rod, one module each (:mod:`matid.rod.terms.base` says what a term gives).

:data:`LOADS` lists the scene's loads in the order the system sums them; :func:`loads_of` builds
those a scene has. A new load is one module here, one entry in LOADS and its keys in
:mod:`matid.rod.scenes`. The three-point bend's support and nose (:mod:`matid.rod.terms.supports`)
are terms held by multipliers, which the bend system (:mod:`matid.rod.bend_system`) binds and sums.
"""

from __future__ import annotations

from matid.rod.terms.base import Scale, Term
from matid.rod.terms.contact import Contact
from matid.rod.terms.distributed import DistributedForce
from matid.rod.terms.gauge import UnityGauge
from matid.rod.terms.magnetisation import Magnetisation
from matid.rod.terms.magnets import Magnets
from matid.rod.terms.point_loads import PointLoads
from matid.rod.terms.supports import Nose, Support
from matid.rod.terms.tip import Tip

#: Every load a cantilever scene may have, in the order their residuals are summed.
LOADS = (Magnetisation, DistributedForce, Tip, Magnets, PointLoads, Contact)


def loads_of(scene, scale: Scale) -> tuple[Term, ...]:
    """The terms of the loads ``scene`` has (scaled by ``scale``); none for a load it does not have."""
    built = (kind.from_scene(scene, scale) for kind in LOADS)
    return tuple(term for term in built if term is not None)


__all__ = [
    "LOADS",
    "Contact",
    "DistributedForce",
    "Magnetisation",
    "Magnets",
    "Nose",
    "PointLoads",
    "Scale",
    "Support",
    "Term",
    "Tip",
    "UnityGauge",
    "loads_of",
]
