"""Normal equations of the linear terms, for the global fit's factor and the local re-fair's solve.

Every linear term is ``sum_rows (s_i (L_i y - t_i))^2`` with ``y`` either the patch
control points or the frame points, and separates into the three coordinates. A term
adds ``L^T diag(s^2) L`` and ``L^T (s^2 t)`` to :class:`NormalParts`: per-patch
``(21, 21)`` blocks (bend, local, data: every row lives on one patch) or frame
diagonals (tilt). With the patch points an affine map ``ctrl = A x + c`` of the
unknowns and the frame points unknowns ``x[frame_pos]``, the normal equations are

    H = A^T blkdiag(blocks) A + diag_frames(frame_weight),
    rhs = A^T (patch_rhs - blkdiag(blocks) c) + frames(frame_rhs).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from trispline.spline.index import NCTRL

__all__ = ["NormalParts", "block_diagonal", "normal_equations"]


@dataclass
class NormalParts:
    """Accumulated normal-equation pieces of the linear terms (filled in place by the terms).

    Attributes
    ----------
    blocks : (n, 21, 21) per-patch matrices
    patch_rhs : (n, 21, d) per-patch right-hand sides
    frame_weight : (m,) diagonal weights of the frame points
    frame_rhs : (m, d) right-hand sides of the frame points
    """

    blocks: np.ndarray
    patch_rhs: np.ndarray
    frame_weight: np.ndarray
    frame_rhs: np.ndarray

    @classmethod
    def zeros(cls, n_patches: int, n_frames: int, d: int = 3) -> "NormalParts":
        return cls(np.zeros((n_patches, NCTRL, NCTRL)), np.zeros((n_patches, NCTRL, d)),
                   np.zeros(n_frames), np.zeros((n_frames, d)))


def block_diagonal(blocks: np.ndarray) -> sp.csr_array:
    """``(21 n, 21 n)`` CSR block-diagonal matrix of ``blocks (n, 21, 21)``, built directly."""
    n = blocks.shape[0]
    idx = np.arange(NCTRL)
    indptr = np.arange(0, n * NCTRL * NCTRL + 1, NCTRL, dtype=np.int64)
    indices = np.repeat((np.arange(n, dtype=np.int64) * NCTRL)[:, None] + idx[None, :], NCTRL, axis=0).ravel()
    return sp.csr_array((np.ascontiguousarray(blocks).ravel(), indices, indptr), shape=(n * NCTRL, n * NCTRL))


def normal_equations(A: sp.sparray | sp.spmatrix, c: np.ndarray, frame_pos: np.ndarray,
                     parts: NormalParts) -> tuple[sp.csr_array, np.ndarray]:
    """``H (k, k)`` and ``rhs (k, d)`` of the linear terms (see the module docstring).

    Parameters
    ----------
    A : (21 n, k) patch points per unknown (patch-major storage order)
    c : (21 n, d) fixed part of the patch points
    frame_pos : (m,) unknown of each frame point
    parts : NormalParts of the n patches and m frame points
    """
    k = A.shape[1]
    B = block_diagonal(parts.blocks)
    H = sp.csr_array(A.T @ (B @ A)) + sp.csr_array((parts.frame_weight, (frame_pos, frame_pos)), shape=(k, k))
    H = sp.csr_array(H)
    H.sum_duplicates()
    rhs = np.asarray(A.T @ (parts.patch_rhs.reshape(B.shape[0], -1) - B @ c))
    np.add.at(rhs, frame_pos, parts.frame_rhs)
    return H, rhs
