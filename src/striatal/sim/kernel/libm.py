"""Elementary functions of the kernel: the angle wrap and the C library's exp and log10
as ufuncs, and a polynomial sin/cos for loops that vectorise.

Angles in [rad]; theta = 0 upright.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize

__all__ = [
    "TWO_PI",
    "exp_libm",
    "log10_libm",
    "sincos_poly",
    "wrap_angle",
    "wrap_angles",
]

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def wrap_angle(theta: float) -> float:
    """Angle wrapped to (-pi, pi] [rad]: theta - 2 pi ceil((theta - pi) / 2 pi).

    For |theta| < 3 the ceil is 0 and the formula returns theta itself, so that case
    skips the division (bit for bit the same; tests/test_dynamics.py checks it).
    """
    if -3.0 < theta < 3.0:
        return theta
    return theta - TWO_PI * math.ceil((theta - math.pi) / TWO_PI)


@vectorize(cache=True)
def wrap_angles(theta: float) -> float:
    """:func:`wrap_angle` as a NumPy ufunc: any array shape, the same formula bit for bit.

    This and the two below are compiled at their first call, for the input's dtype (a
    signature list would compile them at every import of this module: 0.2 s of
    LLVM work, at start-up, for every command)."""
    return wrap_angle(theta)


@vectorize(cache=True)
def exp_libm(x: float) -> float:
    """exp(x) elementwise by the C library, as ``math.exp``: the same bits on every CPU.

    NumPy's own ``np.exp`` (and log10, tanh, power) take SIMD code paths chosen by
    the CPU (AVX-512 machines get different last bits), so a learning result that
    goes through them would depend on the machine (docs/performance.md).
    """
    return math.exp(x)


@vectorize(cache=True)
def log10_libm(x: float) -> float:
    """log10(x) elementwise by the C library, as ``math.log10`` (see :func:`exp_libm`)."""
    return math.log10(x)


# Polynomial sin/cos (fdlibm's kernels after a Cody-Waite reduction by pi/2): no libm
# call, so a loop over trials vectorises (AVX2: 4 trials per instruction).
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of pi/2
_PIO2_2 = 6.07710050630396597660e-11  # next 33 bits
_PIO2_3 = 2.02226624871116645580e-21  # next 33 bits
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
#: Trials per lockstep block (one block per thread at a time).
LOCKSTEP_BLOCK = 64


@njit(cache=True, error_model="numpy")
def sincos_poly(x: float) -> tuple[float, float]:
    """(sin x, cos x) without libm: x = k pi/2 + r, |r| <= pi/4, fdlibm's polynomials.

    Within about 1 ulp of math.sin/cos for |x| < 1e5 (k exact in the three-part
    pi/2); accuracy degrades slowly beyond (a state that large faults at 1e8).
    Branch-free, so loops over it vectorise.
    """
    k = np.floor(x * _INV_PIO2 + 0.5)
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    sp = r + (z * r) * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cr = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    cp = w + (((1.0 - w) - hz) + z * cr)
    q = k - 4.0 * np.floor(0.25 * k)  # quadrant 0..3
    odd = (q == 1.0) | (q == 3.0)
    s = cp if odd else sp
    c = sp if odd else cp
    s = -s if q >= 2.0 else s
    c = -c if ((q == 1.0) | (q == 2.0)) else c
    return s, c
