"""Frame-stack accumulators (plain and defect-masked), the 13-component noise decomposition
(three-way ANOVA of the dark, gain part of a flat), regions and channels, result panels, clipped
pixels (found, counted, excluded).
Imports ``kernels``, ``stats``, ``spatial``."""
