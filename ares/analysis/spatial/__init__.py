"""Spatial nonuniformity of images (EMVA 1288 4.0 Linear Sections 4.2, 4.3, 8.1 - 8.5): the
high-/low-pass filters, the row/column/pixel split of a spatial variance (``nonuniformity``)
and its measurement error (``pattern_se``). Imports
``kernels`` and ``stats``."""
