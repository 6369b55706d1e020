"""Newton's cold starts at the full load, for a mesh with no converged state of the scene to start
from: the unloaded arc of a precurved rod (:mod:`matid.rod.arc`), the rod turned into a field beyond
buckling or by a dead tip force (:mod:`matid.rod.aligned`). :func:`matid.rod.cantilever.equilibrium` falls
back on the load continuation from the straight rod when there is none, or Newton fails from it.
"""

from __future__ import annotations

import numpy as np

from matid.rod.aligned import aligned
from matid.rod.arc import arc


def cold_start(system) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(nodal values (nscalar, nf), point stresses for the mixed Newton's first tangent or None: those
    of the displacements) of the scene's cold start, or None when it has none."""
    bent = arc(system)
    return (bent, None) if bent is not None else aligned(system)
