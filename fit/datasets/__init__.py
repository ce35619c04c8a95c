"""Data the project generates itself, and where the real meshes are.

:mod:`.synthetic` (the built-in example scan of ``trispline demo``), :mod:`.face` (a
real-world-like face scan: ragged outline, a hole, irregular sampling, noise, its own
orientation), :mod:`.truth` (analytic surfaces scanned, for the approximation
benchmarks), :mod:`.franke` (scattered-data test functions), :mod:`.checks` (their
common arguments) and :mod:`.cache` (``../shared/data`` or its copy in a cache folder:
``python -m trispline.fit.datasets.cache``).
"""
