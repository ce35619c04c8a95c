"""Normal equations of the linear terms, for the global fit's factor and the local re-fair's solve.

Every linear term is ``sum_rows (s_i (L_i y - t_i))^2`` with ``y`` either the patch
control points or the frame points, and separates into the three coordinates. A term
adds ``L^T diag(s^2) L`` and ``L^T (s^2 t)`` to :class:`NormalParts`: per-patch
``(21, 21)`` blocks (bend, local, data: every row lives on one patch) or frame
diagonals (tilt). With the patch points an affine map ``ctrl = A x + c`` of the
unknowns and the frame points unknowns ``x[frame_pos]``, the normal equations are

    H = A^T blkdiag(blocks) A + diag_frames(frame_weight),
    rhs = A^T (patch_rhs - blkdiag(blocks) c) + frames(frame_rhs).

``H`` is assembled like a finite-element matrix: the 21 rows of ``A`` of a patch touch
few unknowns (18 on average, 20 at most on the benchmark scans), so each patch adds
one small dense ``A_f^T B_f A_f`` over its own unknowns, and the pieces are summed
into CSR once. At 100k faces this takes 1.1 s where the sparse triple product
``A^T (B A)`` took 5.2 s (its ``B A`` alone has 38M entries).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from trispline.spline.index import NCTRL
from trispline.spline.util.memory import index_dtype
from trispline.spline.util.parallel import Workers
from trispline.spline.util.sparse import compact

from ..progress import Report, map_reporting, silent, span
from ..solve import symmetric_from_upper

__all__ = ["NormalParts", "normal_equations", "patch_unknowns", "upper_pattern"]

#: Patches per chunk of the dense products (memory: chunk * 21 * 21 floats per block array).
PATCH_CHUNK = 2048


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


def patch_unknowns(A: sp.csr_array) -> sp.csr_array:
    """``(n, k)`` CSR incidence of the ``n`` patches and their unknowns (sorted columns, values: counts)
    from ``A (21 n, k)`` with sorted indices; ``A`` stays as it is (its index arrays are copied)."""
    n = A.shape[0] // NCTRL
    B = sp.csr_array((np.ones(A.nnz, np.float32), A.indices.copy(), A.indptr[::NCTRL].copy()), shape=(n, A.shape[1]))
    B.sum_duplicates()  # in place: hence the copies
    return B


def _patch_upper(A: sp.csr_array, B: sp.csr_array, blocks: np.ndarray, lo: int, hi: int,
                 out: tuple[np.ndarray, ...], start: int) -> None:
    """Writes the upper-triangle entries ``(row, col, value)`` of ``sum_f A_f^T B_f A_f`` over patches
    ``lo:hi`` into ``out = (rows, cols, vals)`` from ``start`` on (the chunks' entries follow each other).

    ``A_f`` (rows ``21 f .. 21 f + 20`` of ``A``) is made dense over the patch's own sorted
    unknowns ``U_f`` (row ``f`` of the incidence ``B``, :func:`patch_unknowns`); since ``U_f`` is
    sorted, local ``i <= j`` is global ``row <= col``.
    """
    m, k = hi - lo, A.shape[1]
    bp = B.indptr[lo:hi + 1]
    n_unknowns = np.diff(bp)  # (m,) u_f
    first = bp[:-1] - bp[0]
    ucol = B.indices[bp[0]:bp[-1]].astype(np.int64)
    upatch = np.repeat(np.arange(m), n_unknowns)
    width = int(n_unknowns.max()) if m else 0
    U = np.zeros((m, width), out[0].dtype)
    U[upatch, np.arange(ucol.size) - first[upatch]] = ucol
    ptr = A.indptr[NCTRL * lo:NCTRL * hi + 1]
    patch, slot = np.divmod(np.repeat(np.arange(NCTRL * m), np.diff(ptr)), NCTRL)
    # each entry's unknown in U_f: B's (patch, column) keys are sorted
    local = np.searchsorted(upatch * k + ucol, patch * k + A.indices[ptr[0]:ptr[-1]]) - first[patch]
    Ad = np.zeros((m, NCTRL, width))
    Ad[patch, slot, local] = A.data[ptr[0]:ptr[-1]]  # CSR rows hold no duplicate columns
    K = np.matmul(Ad.transpose(0, 2, 1), np.matmul(blocks[lo:hi], Ad))  # (m, u, u)
    iu, ju = np.triu_indices(width)
    keep = ju[None, :] < n_unknowns[:, None]  # (m, pairs): both unknowns exist (iu <= ju)
    stop = start + int(np.count_nonzero(keep))
    np.compress(keep.ravel(), U[:, iu], out=out[0][start:stop])
    np.compress(keep.ravel(), U[:, ju], out=out[1][start:stop])
    np.compress(keep.ravel(), K[:, iu, ju], out=out[2][start:stop])


def _patch_entries(A: sp.csr_array, blocks: np.ndarray, frame_pos: np.ndarray, frame_weight: np.ndarray,
                   report: Report | None, incidence: sp.csr_array | None = None) -> tuple[np.ndarray, ...]:
    """COO ``(rows, cols, vals)`` of the patches' upper-triangle entries, then the frames' diagonal.

    The chunks write in place into arrays sized from the patches' unknowns (no pieces to
    concatenate: 0.2 CPU s and 270 MB less at 100k faces). ``incidence``: :func:`patch_unknowns`
    of ``A`` where the caller has it.
    """
    n, k = blocks.shape[0], A.shape[1]
    B = patch_unknowns(A) if incidence is None else incidence
    u = np.diff(B.indptr)
    offset = np.zeros(n + 1, np.int64)
    np.cumsum(u * (u + 1) // 2, out=offset[1:])  # each patch's pairs i <= j of its unknowns
    m, base = frame_pos.size, int(offset[-1])
    idx = index_dtype(k)
    out = (np.empty(base + m, idx), np.empty(base + m, idx), np.empty(base + m))
    with Workers(n, parallel_min=2 * PATCH_CHUNK) as work:
        map_reporting(work, lambda lo, hi: _patch_upper(A, B, blocks, lo, hi, out, int(offset[lo])), n, PATCH_CHUNK,
                      report)
    out[0][base:] = frame_pos
    out[1][base:] = frame_pos
    out[2][base:] = frame_weight
    return out


def _upper_matrix(A: sp.csr_array, parts: NormalParts, frame_pos: np.ndarray, report: Report | None = None,
                  incidence: sp.csr_array | None = None, release: bool = False) -> sp.csr_array:
    """``(k, k)`` CSR upper triangle (diagonal included) of ``A^T blkdiag(parts.blocks) A + diag_frames``.

    ``release``: drop ``parts.blocks`` (set to None) once their entries are written, before the
    entries become CSR (at 100k faces the blocks are 337 MiB, the COO entries 274 and the CSR
    conversion's arrays 205: the assembly's peak)."""
    k = A.shape[1]
    rows, cols, vals = _patch_entries(A, parts.blocks, np.asarray(frame_pos), np.asarray(parts.frame_weight, float),
                                      span(report, 0.0, 0.6), incidence)
    if release:
        parts.blocks = None
    U = sp.csr_array((vals, (rows, cols)), shape=(k, k))
    del rows, cols, vals
    U.sum_duplicates()
    compact(U)  # the sums are views of the COO-sized buffers (duplicates included): 80 MB more at 100k faces
    (report or silent)(1.0)
    return U


def upper_pattern(A: sp.csr_array, incidence: sp.csr_array | None = None) -> sp.csr_array:
    """``(k, k)`` CSR pattern (values: shared-patch counts) of the upper triangle :func:`normal_equations`
    returns, from ``A (21 n, k)`` (sorted indices) alone: every two unknowns of one patch couple (the
    frame points' diagonal lies inside). Known before any term is set up
    (:class:`~trispline.fit.solve.PatternAnalysis`).

    The product ``S = B^T B`` of the patch incidence has unsorted rows; its lower triangle's CSC is
    the upper triangle's CSR with sorted columns (a counting sort: 3x faster than ``scipy.sparse.triu``
    and a sort of the rows). ``incidence``: :func:`patch_unknowns` of ``A`` where the caller has it.
    """
    B = patch_unknowns(A) if incidence is None else incidence
    S = B.T @ B
    k = S.shape[0]
    row = np.repeat(np.arange(k, dtype=S.indices.dtype), np.diff(S.indptr))
    lower = S.indices <= row
    ptr = np.zeros(k + 1, S.indptr.dtype)
    np.cumsum(np.bincount(row[lower], minlength=k), out=ptr[1:])
    C = sp.csr_array((S.data[lower], S.indices[lower], ptr), shape=(k, k)).tocsc()  # sorted within columns
    return sp.csr_array((C.data, C.indices, C.indptr), shape=(k, k))


def _patch_residual_rhs(parts: NormalParts, c: np.ndarray) -> np.ndarray:
    """``(n, 21, d)`` ``patch_rhs - blocks @ c`` for the fixed part ``c (n, 21, d)``, in chunks of patches
    on a thread per core (100k batched 21 x 21 products: 0.3 s on one core)."""
    r = np.empty_like(parts.patch_rhs)

    def chunk(lo: int, hi: int) -> None:
        np.matmul(parts.blocks[lo:hi], c[lo:hi], out=r[lo:hi])
        np.subtract(parts.patch_rhs[lo:hi], r[lo:hi], out=r[lo:hi])

    with Workers(len(r), parallel_min=2 * PATCH_CHUNK, serial_blas=True) as work:
        work.map(chunk, len(r), PATCH_CHUNK)
    return r


def normal_equations(A: sp.sparray | sp.spmatrix, c: np.ndarray, frame_pos: np.ndarray,
                     parts: NormalParts, *, upper: bool = False, report: Report | None = None,
                     incidence: sp.csr_array | None = None, release: bool = False) -> tuple[sp.csr_array, np.ndarray]:
    """``H (k, k)`` and ``rhs (k, d)`` of the linear terms (see the module docstring).

    Parameters
    ----------
    A : (21 n, k) patch points per unknown (patch-major storage order)
    c : (21 n, d) fixed part of the patch points
    frame_pos : (m,) unknown of each frame point
    parts : NormalParts of the n patches and m frame points
    upper : return only the upper triangle of ``H`` (diagonal included): all a
        symmetric factorisation reads, at half the memory
    report : progress as chunks of patches finish (:mod:`trispline.fit.progress`)
    incidence : (n, k) :func:`patch_unknowns` of ``A`` (sorted indices), where the caller made it
        already (:func:`upper_pattern` needs it too); else made here
    release : consume ``parts``: its ``blocks`` and ``patch_rhs`` are set to None once read, so that
        the blocks (337 MiB at 100k faces) are freed before the entries become CSR

    Returns
    -------
    H : (k, k) CSR, rhs : (k, d)
    """
    A = sp.csr_array(A)
    A.sort_indices()
    n, d = parts.blocks.shape[0], parts.patch_rhs.shape[2]
    r = _patch_residual_rhs(parts, np.asarray(c).reshape(n, NCTRL, d))
    rhs = np.asarray(A.T @ r.reshape(n * NCTRL, d))
    del r
    np.add.at(rhs, frame_pos, parts.frame_rhs)
    if release:
        parts.patch_rhs = None
    U = _upper_matrix(A, parts, frame_pos, report, incidence, release)
    return (U if upper else symmetric_from_upper(U)), rhs
