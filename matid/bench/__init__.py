"""``matid bench``: accuracy, cost and robustness of the rod solver, measured.

Sections (each a module with ``run(quick) -> dict``):

- :mod:`matid.bench.convergence`: error against elements and against run time
  for each element and quadrature choice, with the observed order;
- :mod:`matid.bench.stability`: stiff and extreme cases (:mod:`matid.bench.catalogue`, on
  :mod:`matid.bench.case` and :mod:`matid.bench.measures`), each classified as "ok",
  "raised ConvergenceError", or a loud failure ("wrong", ...), each with its expected outcome;
- :mod:`matid.bench.leave_out`: which model and energy terms ran, and the time
  the planar reduction saves;
- :mod:`matid.bench.vs3d`: the 1D rod against a 3D scikit-fem tube (:mod:`matid.bench.tube_fe`,
  :mod:`matid.bench.tube_section`, :mod:`matid.bench.extrapolation`);
- :mod:`matid.bench.peers`: ``solve()`` against a scipy ``solve_bvp`` baseline.

:func:`matid.bench.cli.run_bench` writes ``bench.json``, ``bench.html`` and the
plots; references are computed at run time, never stored.
"""
