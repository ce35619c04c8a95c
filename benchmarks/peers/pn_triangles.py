"""Curved PN triangles (Vlachos, Peters, Boyd and Mitchell 2001): a cubic Bezier triangle per face.

    pts, nrm = pn_triangles(V, F, bary)      # (nf, n, 3) points and unit normals at bary (n, 3)

The control net of face ``(P1, P2, P3)`` with vertex normals ``N_i`` (area-weighted face
normals of the mesh): corners ``P_i``; edge points ``b_210 = (2 P1 + P2 - w_12 N1) / 3`` with
``w_ij = (P_j - P_i) . N_i`` (the edge's third points projected into the corner's tangent
plane); centre ``b_111 = E + (E - V) / 2`` (``E`` the mean of the six edge points, ``V`` of the
corners). The cubic net is degree-raised to the quintic storage order, so evaluation and
derivatives use trispline's own Bernstein basis. Normals are the patch's geometric normals
(PN triangles' separate quadratic normal field is a shading device, not the surface's).
"""
from __future__ import annotations

import numpy as np

from trispline.fit.render.geometry import unit_normals
from trispline.fit.targets import area_weighted_normals
from trispline.spline.bernstein import basis, basis_gradient_bary
from trispline.spline.index import lattice


def elevation(degree: int) -> np.ndarray:
    """``(m', m)`` matrix raising a Bezier triangle's net from ``degree`` to ``degree + 1`` (lattice orders)."""
    lo, hi = lattice(degree), lattice(degree + 1)
    pos = {tuple(int(x) for x in e): n for n, e in enumerate(lo)}
    E = np.zeros((len(hi), len(lo)))
    for r, e in enumerate(hi):
        for k in range(3):
            if e[k] > 0:
                f = e.copy()
                f[k] -= 1
                E[r, pos[tuple(int(x) for x in f)]] += e[k] / (degree + 1)
    return E


def pn_control_net(V: np.ndarray, F: np.ndarray, N: np.ndarray) -> np.ndarray:
    """``(nf, 10, 3)`` cubic nets in lattice(3) order (``(3,0,0), (2,1,0), (2,0,1), ...``)."""
    P = V[F]  # (nf, 3, 3)
    Nn = N[F]

    def third(i: int, j: int) -> np.ndarray:
        w = ((P[:, j] - P[:, i]) * Nn[:, i]).sum(1, keepdims=True)
        return (2 * P[:, i] + P[:, j] - w * Nn[:, i]) / 3

    b210, b201, b120, b021, b102, b012 = third(0, 1), third(0, 2), third(1, 0), third(1, 2), third(2, 0), third(2, 1)
    E = (b210 + b201 + b120 + b021 + b102 + b012) / 6
    b111 = E + (E - P.mean(1)) / 2
    # lattice(3): 300 210 201 120 111 102 030 021 012 003
    return np.stack([P[:, 0], b210, b201, b120, b111, b102, P[:, 1], b021, b012, P[:, 2]], axis=1)


def pn_triangles(V: np.ndarray, F: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and unit geometric normals ``(nf, n, 3)`` of every face's PN triangle at ``bary (n, 3)``."""
    net = pn_control_net(V, F, area_weighted_normals(V, F))
    quintic = np.einsum("pm,mq,fqd->fpd", elevation(4), elevation(3), net)  # (nf, 21, 3)
    B = basis(bary)
    Ga, Gb, Gc = basis_gradient_bary(bary)
    pts = np.einsum("nk,fkd->fnd", B, quintic)
    t1 = np.einsum("nk,fkd->fnd", Gb - Ga, quintic)
    t2 = np.einsum("nk,fkd->fnd", Gc - Ga, quintic)
    return pts, unit_normals(t1, t2)
