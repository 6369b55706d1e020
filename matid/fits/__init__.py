"""Identification: one module per test kind, plus the statistics they share.

- :mod:`matid.fits.extension`: standard linear solid (and beyond) on extension runs -> E_e
- :mod:`matid.fits.linear`: E_b (magnetic bending) and E_t (torsion), linear range
- :mod:`matid.fits.shear`: E_s from the three-point bend by the Cosserat rod model
"""
