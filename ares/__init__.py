"""ARES: image-sensor characterization and test bench.

Layers (dependencies point one way only):
``gui, cli -> scan -> hardware, analysis, report -> protocol``; ``sim`` implements the
``hardware`` interfaces; ``analysis`` is pure numpy/scipy; nothing below ``gui`` imports Qt.
"""

__version__ = "0.1.0"
