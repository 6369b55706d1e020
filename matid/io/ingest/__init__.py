"""Reading raw test-machine records: layout detection, columns and units, checks."""
