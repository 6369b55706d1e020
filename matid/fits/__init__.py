"""Identification: one module per test kind, plus the statistics they share.

- :mod:`matid.fits.extension.fit`: standard linear solid on extension runs -> E_e
  (model in :mod:`matid.physics.sls`; parts: ``runs``, ``lsq``, ``stats``, ``checks``)
- :mod:`matid.fits.extension.prony`: n-term Prony solid, chosen against the SLS by BIC
- :mod:`matid.fits.linear`: lines with tare offsets, linear range, sign (shared by the next two)
- :mod:`matid.fits.bending`: E_b from magnetic bending
- :mod:`matid.fits.torsion`: E_t from torsion
- :mod:`matid.fits.stats`: noise, lack of fit, intervals under correlated residuals
- :mod:`matid.fits.shear.fit`: E_s from the three-point bend by the Cosserat rod model
"""
