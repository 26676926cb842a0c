"""The few functions a law's formula may call besides + - * / and comparisons, each working
on floats (also inside numba kernels, through overloads), on sympy expressions (from which
the partial derivatives are generated) and on Exudyn symbolic Reals (the Exudyn model's
user functions): a law's formula is written once and evaluated by all three.

Branches are `where(condition, a, b)`: numba evaluates both sides (the laws keep both
finite), sympy makes a Piecewise, Exudyn an IfThenElse (lazy)."""

from __future__ import annotations

import math

from numba.extending import overload

__all__ = ["sqrt", "fabs", "exp", "sign", "where"]


def _kind(*xs):
    """"esym", "sympy" or "float": the backend of the arguments."""
    for x in xs:
        mod = type(x).__module__
        if mod.startswith("exudyn"):
            return "esym"
    for x in xs:
        if type(x).__module__.startswith("sympy"):
            return "sympy"
    return "float"


def _esym():
    import exudyn as exu

    return exu.symbolic


def sqrt(x):
    """Square root."""
    kind = _kind(x)
    if kind == "esym":
        return _esym().sqrt(x)
    if kind == "sympy":
        import sympy

        return sympy.sqrt(x)
    return math.sqrt(x)


def exp(x):
    """Exponential."""
    kind = _kind(x)
    if kind == "esym":
        return _esym().exp(x)
    if kind == "sympy":
        import sympy

        return sympy.exp(x)
    return math.exp(x)


def fabs(x):
    """Absolute value (sympy: a Piecewise, so that its derivative is +-1, not sign(x))."""
    kind = _kind(x)
    if kind == "esym":
        return _esym().abs(x)
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((x, x >= 0), (-x, True))
    return abs(x)


def sign(x):
    """1 for x > 0, else -1 (Exudyn's sign, 0 at x = 0: laws use it only where x != 0)."""
    kind = _kind(x)
    if kind == "esym":
        return _esym().sign(x)
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((1, x > 0), (-1, True))
    return 1.0 if x > 0.0 else -1.0


def where(condition, a, b):
    """a where `condition` holds, else b."""
    kind = _kind(condition, a, b)
    if kind == "esym":
        esym = _esym()
        wrap = [v if _kind(v) == "esym" else esym.Real(float(v)) for v in (a, b)]
        return esym.IfThenElse(condition, wrap[0], wrap[1])
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((a, condition), (b, True))
    return a if condition else b


@overload(sqrt)
def _sqrt(x):
    return lambda x: math.sqrt(x)


@overload(exp)
def _exp(x):
    return lambda x: math.exp(x)


@overload(fabs)
def _fabs(x):
    return lambda x: abs(x)


@overload(sign)
def _sign(x):
    return lambda x: 1.0 if x > 0.0 else -1.0


@overload(where)
def _where(condition, a, b):
    return lambda condition, a, b: a if condition else b
