"""matid: stiffness identification of catheter tubes for special Cosserat rod models.

Pipeline: study -> measurements -> fits -> results -> report/export,
and scene -> solve -> solution for the embedded rod solver.
"""

__version__ = "0.1.0"
