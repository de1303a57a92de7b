"""ARES desktop GUI (PySide6 + pyqtgraph). Nothing else in ``ares`` imports this package.

Layout (models hold state and are tested without Qt; views only draw them):

- ``events``        the event vocabulary the window draws from (no Qt)
- ``engine``        job protocol, ``DemoScan`` (built-in), ``open_scan(path)`` (no Qt)
- ``runner_adapter`` a scan XML run by ``ares.scan.Runner`` with the window's regions, output
                    options and system; events translated (no Qt)
- ``image_job``     Input Images: recorded frames analysed as ``ares analyze`` (no Qt)
- ``models/``       regions + RoA file, stats panels (range modes), profiles, images,
                    PTC, defect counts and map, progress, views + stage store, the
                    Instrumentation bench, ``SessionModel`` (no Qt; hidden tabs computed when shown)
- ``worker``        ``ScanThread``: a job in a Python thread, events polled through a coalescing,
                    time-decimating pump
- ``plots/``        pyqtgraph views: image + region outlines + defect overlay + New Region drag,
                    histogram, profiles, PTC, pixel distributions, sweep map, components, defect table
- ``scan_panel``, ``instrument_panel``, ``regions_table``, ``results_panel``, ``view_bar``,
  ``info_panel``, ``layout``, ``main_window``
- ``app``           display check (one sentence when Qt cannot start) and startup

Start it with ``ares gui [SCAN]``.

May import every package of ARES; nothing imports it but ``ares.cli``."""
