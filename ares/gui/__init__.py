"""ARES desktop GUI (PySide6 + pyqtgraph). Nothing else in ``ares`` imports this package.

Layout (models hold state and are tested without Qt; views only draw them):

- ``events``        the event vocabulary the window draws from (no Qt)
- ``engine``        job protocol, ``DemoScan`` (built-in), ``open_scan(path)`` (no Qt)
- ``runner_adapter`` a scan XML run by ``ares.scan.Runner``, events translated (no Qt)
- ``models/``       regions + RoA file, stats panels (range modes), profiles, images,
                    PTC, defect counts, progress, ``SessionModel`` (no Qt)
- ``worker``        ``ScanThread``: a job in a Python thread, events polled through a coalescing pump
- ``plots/``        pyqtgraph views: image + region outlines, histogram, profiles, PTC,
                    pixel distributions, defect table
- ``scan_panel``, ``regions_table``, ``results_panel``, ``info_panel``, ``main_window``
- ``app``           display check (one sentence when Qt cannot start) and startup

Start it with ``ares gui [SCAN]``.
"""
