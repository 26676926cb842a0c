"""sin and cos of one angle together: the Python twin of the compiled models' `mbs_sincos`
(core/runtime.h), the same operations in the same order, for Python code that must agree
with the compiled model to the last bit (validation/paper_closed_form.py).

A call of glibc's ``sincos`` per angle was a large share of a model evaluation; this is the
textbook method, written out so that both angles of a model evaluation are computed side by
side: reduction by pi/2 in two parts (Cody & Waite; the
high part has 33 significant bits, so k * hi is exact for |k| < 2^20), then the Taylor series
of sin and cos on |r| <= pi/4, whose truncation (r^19/19!, r^20/20!) is below 1e-19 there.
Tested against ``math.sin``/``math.cos`` to an absolute 2.3e-16 (tests/unit/test_trig.py) for
|x| up to 1e5 rad: absolute, not relative, near the zeros, which suits the model (the results
are added to terms of order one); the angles here are the crank angle (omega t, tens to
thousands of rad) and the coupler angle (below 1 rad).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = ["sincos"]

# pi/2 from its decimal expansion, split into a 33-bit high part and the rest
_PI = Fraction("3.14159265358979323846264338327950288419716939937510582097494459")
_PIO2 = _PI / 2
_SCALE = 2.0 ** 32          # pi/2 < 2: 33 significant bits
PIO2_HI = float(Fraction(int(_PIO2 * int(_SCALE)), int(_SCALE)))
PIO2_LO = float(_PIO2 - Fraction(PIO2_HI))
TWO_OVER_PI = float(1 / _PIO2)
_TWO63 = 2.0 ** 63

# Taylor coefficients (-1)^n / (2n+1)! and (-1)^n / (2n)!, from r^3 and r^2 on
_S3, _S5, _S7, _S9, _S11, _S13, _S15, _S17 = (
    float(Fraction((-1) ** n, _fact)) for n, _fact in
    ((1, 6), (2, 120), (3, 5040), (4, 362880), (5, 39916800), (6, 6227020800),
     (7, 1307674368000), (8, 355687428096000)))
_C2, _C4, _C6, _C8, _C10, _C12, _C14, _C16, _C18 = (
    float(Fraction((-1) ** n, _fact)) for n, _fact in
    ((1, 2), (2, 24), (3, 720), (4, 40320), (5, 3628800), (6, 479001600),
     (7, 87178291200), (8, 20922789888000), (9, 6402373705728000)))


def sincos(x):
    """(sin x, cos x) to about 1e-16 absolute for |x| < 1e5 (see the module docstring)."""
    # np.rint keeps k a float (the value of round(), which returns an int): the reduction
    # then does not wait for a conversion to int and back (about 10 cycles on the chain of
    # every model evaluation; the int is needed only for the quadrant, off that chain).
    # Beyond the int64 range (a diverging trial step) k is what that conversion gave,
    # x86's -2^63, so that such a step gives the same nonsense as before: NaN or not
    # decides how much the integrator shrinks the rejected step
    k = np.rint(x * TWO_OVER_PI)
    if not abs(k) < _TWO63:
        k = -_TWO63
    r = (x - k * PIO2_HI) - k * PIO2_LO
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    # Estrin's scheme: short dependency chains, the two series side by side
    ps = ((_S3 + _S5 * r2) + (_S7 + _S9 * r2) * r4
          + ((_S11 + _S13 * r2) + (_S15 + _S17 * r2) * r4) * r8)
    pc = ((_C4 + _C6 * r2) + (_C8 + _C10 * r2) * r4
          + ((_C12 + _C14 * r2) + (_C16 + _C18 * r2) * r4) * r8)
    s = r + r * r2 * ps
    c = 1.0 + r2 * (_C2 + r2 * pc)
    q = int(k) & 3
    if q == 0:
        return s, c
    if q == 1:
        return c, -s
    if q == 2:
        return -s, -c
    return -c, s
