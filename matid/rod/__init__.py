"""The static Cosserat rod solver: scenes -> solve -> solution.

>>> from matid.rod import load_scene, solve
>>> sol = solve(load_scene("examples/scenes/magnetic_cantilever.toml"))  # doctest: +SKIP
>>> sol.model, sol.tip["position"]  # doctest: +SKIP
"""

from matid.rod.api import solve
from matid.rod.bend import BendGeometry, BendModel
from matid.rod.cantilever import Solution
from matid.rod.many import Failure, solve_many
from matid.rod.scenes import Scene, load_scene
from matid.rod.sweeps import sweep

__all__ = [
    "BendGeometry",
    "BendModel",
    "Failure",
    "Scene",
    "Solution",
    "load_scene",
    "solve",
    "solve_many",
    "sweep",
]
