"""Eigen-decomposition of a real matrix with complex eigenvalues, for numba kernels.

numba's ``np.linalg.eig`` of a real matrix refuses complex eigenvalues, so a real first-order
matrix had to be decomposed as a complex one (LAPACK ``zgeev``).  LAPACK's real ``dgeev``
finds the same eigenpairs in real arithmetic, faster (docs/performance.md), and returns a
complex pair as the real and imaginary parts of one eigenvector.  This module calls SciPy's ``dgeev``
(``scipy.linalg.cython_lapack``, the LAPACK SciPy is built with) from compiled code: its address
is registered with LLVM under a fixed name, so kernels that call it can be cached on disk.
"""

from __future__ import annotations

import numpy as np
from llvmlite import binding as llvm
from numba import njit, types
from numba.extending import get_cython_function_address

__all__ = ["real_eig"]

_SYMBOL = "beamsim_scipy_dgeev"
llvm.add_symbol(_SYMBOL, get_cython_function_address("scipy.linalg.cython_lapack", "dgeev"))

_int = types.CPointer(types.int32)
_dbl = types.CPointer(types.float64)
_chr = types.CPointer(types.uint8)
#: Fortran ``dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)``
_dgeev = types.ExternalFunction(_SYMBOL, types.void(_chr, _chr, _int, _dbl, _int, _dbl, _dbl,
                                                   _dbl, _int, _dbl, _int, _dbl, _int, _int))


@njit(cache=True)
def real_eig(A):
    """Eigenvalues ``lam`` and right eigenvectors ``V`` (columns) of the real square matrix
    ``A``, ``A V = V diag(lam)``, ordered as ``nc`` eigenvalues with ``Im lam > 0``, the real
    ones, then the conjugates of the first ``nc`` in the same order (exact conjugates, with
    conjugate eigenvectors).  Returns ``(lam, V, nh, nc)`` with ``nh = n - nc``; raises if
    LAPACK fails to converge.  Eigenvectors have unit 2-norm (LAPACK's normalisation)."""
    n = A.shape[0]
    # column-major copy of A: row c of ``a`` is column c of A
    a = np.empty((n, n))
    for r in range(n):
        for c in range(n):
            a[c, r] = A[r, c]
    jobvl = np.array([ord("N")], np.uint8)
    jobvr = np.array([ord("V")], np.uint8)
    nn = np.array([n], np.int32)
    one = np.array([1], np.int32)
    wr = np.empty(n)
    wi = np.empty(n)
    vl = np.empty(1)
    vr = np.empty((n, n))
    info = np.zeros(1, np.int32)
    query = np.empty(1)
    lwork = np.array([-1], np.int32)
    _dgeev(jobvl.ctypes, jobvr.ctypes, nn.ctypes, a.ctypes, nn.ctypes, wr.ctypes, wi.ctypes,
           vl.ctypes, one.ctypes, vr.ctypes, nn.ctypes, query.ctypes, lwork.ctypes, info.ctypes)
    lwork[0] = max(4 * n, int(query[0]))
    work = np.empty(lwork[0])
    _dgeev(jobvl.ctypes, jobvr.ctypes, nn.ctypes, a.ctypes, nn.ctypes, wr.ctypes, wi.ctypes,
           vl.ctypes, one.ctypes, vr.ctypes, nn.ctypes, work.ctypes, lwork.ctypes, info.ctypes)
    if info[0] != 0:
        raise np.linalg.LinAlgError("dgeev did not converge")
    nc = 0
    for k in range(n):
        if wi[k] > 0.0:
            nc += 1
    nh = n - nc
    lam = np.empty(n, np.complex128)
    V = np.empty((n, n), np.complex128)
    ip = 0
    ir = nc
    k = 0
    while k < n:
        if wi[k] > 0.0:
            # a pair: columns k, k + 1 (rows of vr) hold Re and Im of the eigenvector of wr + i wi
            lam[ip] = wr[k] + 1j * wi[k]
            lam[nh + ip] = wr[k] - 1j * wi[k]
            for r in range(n):
                V[r, ip] = vr[k, r] + 1j * vr[k + 1, r]
                V[r, nh + ip] = vr[k, r] - 1j * vr[k + 1, r]
            ip += 1
            k += 2
        else:
            lam[ir] = wr[k]
            for r in range(n):
                V[r, ir] = vr[k, r]
            ir += 1
            k += 1
    return lam, V, nh, nc
