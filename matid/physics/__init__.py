"""The paper's equations in numpy only: kinematics, energy densities, the SLS, contact, moduli."""
