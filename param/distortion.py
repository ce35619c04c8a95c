"""Per-face distortion of a map from a 3D mesh to the plane, and summary percentiles."""
from __future__ import annotations

import numpy as np

#: Percentiles reported for each distortion measure.
PERCENTILES = (50, 90, 99)


def face_jacobians(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Jacobians ``(nf, 2, 2)`` of the affine map from each 3D face (in a local
    orthonormal frame of its plane) to its uv triangle."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1, e2 = b - a, c - a
    x = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    n = np.cross(e1, e2)
    y = np.cross(n, x)
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    P = np.stack([np.stack([(e1 * x).sum(1), (e2 * x).sum(1)], -1),
                  np.stack([(e1 * y).sum(1), (e2 * y).sum(1)], -1)], axis=1)  # (nf, 2, 2) columns = edges
    q0 = uv[F[:, 0]]
    Q = np.stack([uv[F[:, 1]] - q0, uv[F[:, 2]] - q0], axis=-1)  # (nf, 2, 2)
    det = P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] * P[:, 1, 0]
    Pinv = np.stack([np.stack([P[:, 1, 1], -P[:, 0, 1]], -1),
                     np.stack([-P[:, 1, 0], P[:, 0, 0]], -1)], axis=1) / det[:, None, None]
    return Q @ Pinv


def face_distortion(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(angle, area)``, each ``(nf,)`` and >= 1 (1 = no distortion).

    ``angle`` is the ratio of singular values ``s1 / s2`` of each face's Jacobian
    (1 for a conformal map: a similarity on every face); ``area`` is ``max(r, 1/r)`` of the face's share of
    the total uv area over its share of the total 3D area.
    """
    J = face_jacobians(V, F, uv)
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    q = np.hypot(0.5 * (a + d), 0.5 * (c - b))  # closed-form 2x2 singular values
    r_ = np.hypot(0.5 * (a - d), 0.5 * (c + b))
    with np.errstate(divide="ignore", invalid="ignore"):
        angle = (q + r_) / np.abs(q - r_)
        det = np.abs(a * d - b * c)
        a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
        r = det * (a3.sum() / (a3 * det).sum())  # (uv area / total uv) / (3D area / total 3D)
        area = np.maximum(r, 1.0 / r)
    return angle, area


def summarize(angle: np.ndarray, area: np.ndarray) -> dict:
    """Flat dict ``angle_p50 ... angle_max, area_p50 ... area_max`` (floats)."""
    out: dict = {}
    for name, x in (("angle", angle), ("area", area)):
        x = np.where(np.isfinite(x), x, np.inf)
        for p, val in zip(PERCENTILES, np.percentile(x, PERCENTILES)):
            out[f"{name}_p{p}"] = float(val)
        out[f"{name}_max"] = float(x.max())
    return out
