"""Numba kernels and their compile helpers (``compile``): one-pass folds of frame stacks, the EMVA
1288 high-/low-pass, pair moments, and the array recycler they share. Imports nothing of ARES."""
