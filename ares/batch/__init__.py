"""Many sensors, many runs: ``ares batch`` on Dask (``cluster``), what a worker computes per
item and its cache (``items``), the lot report (``lot_report``, ``lot_pdf``), bins and
outlier screens (``screens``), the results database (``db``, ``dbconn``, ``dbschema``,
``migrations``), STDF V4 (``stdf``), certificates (``certificate``), trends (``trend``) and
cheap simulated lots to try the workflow on (``demo``).

May import ``scan`` and everything below it; never ``commands`` or ``gui``."""
