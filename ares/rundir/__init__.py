"""The run directory on disk: the writer (stages committed as they end), the reader
(``load_run``), the run's state (``state``), its integrity check (``check``) and the
comparison of two runs (``compare``). Imports ``protocol``, ``analysis`` and the base modules."""
