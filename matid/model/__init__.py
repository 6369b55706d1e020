"""What a study is and what a fit returns, below every fit, reader and writer.

- :mod:`matid.model.study`: specimens, lab tests, fixed stiffnesses, the study;
- :mod:`matid.model.measurement`: a test with the table read from its file;
- :mod:`matid.model.results`: estimates, series, test fits, failures, a study's result;
- :mod:`matid.model.status`: each value's status (ok, check, not_identifiable);
- :mod:`matid.model.views`: read-only mappings of frozen records, and their pickling.

These import numpy, the standard library and :mod:`matid.physics` (a specimen's section)
only: fits and rod build on them, io reads files into them and writes them out.
"""
