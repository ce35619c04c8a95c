"""Plumbing shared by every layer: no mathematics here.

``gather`` (row gathers faster than fancy indexing), ``memory`` (compact index
types, large arrays faulted in on every core), ``parallel`` (ranges of work on a
thread per core), ``sparse`` (threaded CSR products), ``atomic`` (all-or-nothing
output files) and ``timer`` (named stage timings). Not part of the stable API:
import the module you need, e.g. ``from trispline.spline.util import atomic``.
"""
