"""What a run's stages mean: the scan-level analyses (photon transfer, dark current, EMVA 1288,
MTF, photon counting, spectral QE ...) registered by name (``registry``), and the limits.
Imports ``rundir``, ``rig``, ``protocol``, ``sim``, ``hardware``, ``analysis``; never ``report``
or ``scan``."""

# every built-in analysis registers itself on import (``registry.register_scan_analysis``)
from ares.results import adc, analyses, emva1288, emva4, lowlight, mtf, photon_counting, spectral_qe  # noqa: E402,F401
