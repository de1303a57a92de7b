"""Statistics every room uses: a value with its SE and verdict (``estimate``), physical-range
guards, small weighted fits, splines, order statistics and distribution tails. Imports only
``ares.analysis.kernels`` and ``ares.errors``."""
