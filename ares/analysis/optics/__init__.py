"""Beyond the photon-transfer set: slanted-edge MTF, photon counting, spectral QE. Imports
``stats`` (and rooms below ``emva``), never ``emva``."""
