"""Low light and heat: random-telegraph pixels (``rtn``; their dwell times
``rtn_dwell``), dark current against temperature per
pixel (``arrhenius``), the Fe-55 X-ray gain (``fe55``).

Pure numpy (no Qt, no file I/O). A room at the level of ``optics`` and ``defects``: imports
``kernels``, ``stats``, ``spatial``, ``noise`` and ``ptc``, never ``emva``, ``optics`` or
``defects``."""
