"""The test kinds matid fits, one line each, in fit and report order (docs/contract.md section 1).

A kind is declared once, by its own fits module (a :class:`~matid.model.kind.Kind`); the
study loader, ingest, the pipeline, the CLI and the report read this list and name no kind
themselves. Extension and magnetic bending come before the three-point bend, whose fit
needs E_e and E_b of the same specimen.
"""

from __future__ import annotations

from matid.fits.bending import KIND as MAGNETIC_BENDING
from matid.fits.extension.fit import KIND as EXTENSION
from matid.fits.shear.fit import KIND as THREE_POINT_BEND
from matid.fits.torsion import KIND as TORSION
from matid.model.kind import Kind

KINDS: tuple[Kind, ...] = (
    EXTENSION,
    MAGNETIC_BENDING,
    TORSION,
    THREE_POINT_BEND,
)
#: name -> kind.
BY_NAME: dict[str, Kind] = {k.name: k for k in KINDS}
