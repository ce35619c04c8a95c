"""Peers of trispline's 3D fit, implemented here in numpy for the benchmarks (vectorised, no dependency).

* :mod:`.pn_triangles`: curved PN triangles (Vlachos et al. 2001), a cubic Bezier triangle per
  face from the vertices and their normals; C0, interpolating.
* :mod:`.subdivision`: the interpolating modified Butterfly scheme (Zorin, Schroeder and
  Sweldens 1996) and Loop subdivision (approximating, evaluated at its limit positions).

Each evaluates on the same per-face sample lattice as the spline (:func:`trispline.spline.index.lattice`),
so every method is measured at the same points of every mesh face.
"""
