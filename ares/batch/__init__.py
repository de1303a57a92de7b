"""Many sensors, many runs: ``ares batch`` on Dask (``cluster``), what a worker computes per
item and its cache (``items``), the lot report (``lot_report``).

May import ``scan`` and everything below it; never ``commands`` or ``gui``."""
