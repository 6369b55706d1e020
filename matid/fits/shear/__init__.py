"""E_s: the three-point-bend problem fitted with the rod solver in the loop, and torsion's E_s."""
