"""Post-processing and study tools on top of the results-file contract.

* :mod:`~mpsfem.tools.results_series`: read the time series of a results file (probes, structure
  members, coupling windows) as uniform :class:`~mpsfem.tools.results_series.Series`.
* :mod:`~mpsfem.tools.reference_csv`: read a reference curve (measured or published data) from CSV.
* :mod:`~mpsfem.tools.plot`: ``mpsfem plot`` (one PNG per series, references overlaid).
* :mod:`~mpsfem.tools.grid`, :mod:`~mpsfem.tools.peaks`, :mod:`~mpsfem.tools.sweep`:
  ``mpsfem sweep`` (parameter grids run as ``mpsfem`` child processes, resumable, summary of
  peaks).

The tools read results files and the scenario schema; solvers run only in child processes.
"""


class ToolError(ValueError):
    """Bad input to a tool (missing file, unknown probe, malformed CSV, bad grid); the message
    says what was given and what is allowed."""


#: the reference-CSV format in one sentence (help text; details in reference_csv and docs/tools.md)
REFERENCE_FORMAT = (
    "rows 'time, value[, value ...]' (s, then SI units of the series), comma-separated "
    "(whitespace if the file has no comma), '#' comment lines and one optional header line "
    "naming the columns"
)
