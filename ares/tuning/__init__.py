"""``ares bench``: run time against accuracy. ``grid`` (the knobs and the scan each setting
makes), ``measure`` (one run: timing split, estimates, truths), ``tradeoff`` (per-setting
bias/spread/SE, Pareto front, recommendation; pure), ``plot`` (error vs time figure).

May import ``scan`` and everything below it."""
