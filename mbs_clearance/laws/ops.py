"""The few functions a law's formula may call besides + - * / and comparisons, each working
on floats (the laws' values in Python: the Exudyn model's friction, the tests), on sympy
expressions (from which the partial derivatives are generated), on Exudyn symbolic Reals
(the Exudyn model's user functions) and on `CExpr` (C source of the formula in its own
order of operations, from which the compiled core's law values are generated): a law's
formula is written once and evaluated by all four.

Branches are `where(condition, a, b)`: the laws keep both sides finite (a formula may be
evaluated on both), sympy makes a Piecewise, Exudyn an IfThenElse (lazy), C a conditional
expression."""

from __future__ import annotations

import math

__all__ = ["sqrt", "fabs", "exp", "sign", "where", "CExpr"]


class CExpr:
    """A C expression recorded by evaluating a formula on it: every operation parenthesised
    in the order Python evaluates it, numbers as round-trip decimal literals, so that the C
    code rounds exactly as the formula evaluated in Python does."""

    def __init__(self, text: str):
        self.text = text

    @staticmethod
    def of(x) -> str:
        """The C text of `x` (a CExpr or a real number)."""
        if isinstance(x, CExpr):
            return x.text
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise TypeError(f"a law formula combines a C expression with {x!r}")
        return repr(float(x))

    def _bin(self, op, other, reverse=False):
        a, b = (CExpr.of(other), self.text) if reverse else (self.text, CExpr.of(other))
        return CExpr(f"({a} {op} {b})")

    def __add__(self, o): return self._bin("+", o)             # noqa: E704
    def __radd__(self, o): return self._bin("+", o, True)      # noqa: E704
    def __sub__(self, o): return self._bin("-", o)             # noqa: E704
    def __rsub__(self, o): return self._bin("-", o, True)      # noqa: E704
    def __mul__(self, o): return self._bin("*", o)             # noqa: E704
    def __rmul__(self, o): return self._bin("*", o, True)      # noqa: E704
    def __truediv__(self, o): return self._bin("/", o)         # noqa: E704
    def __rtruediv__(self, o): return self._bin("/", o, True)  # noqa: E704
    def __lt__(self, o): return self._bin("<", o)              # noqa: E704
    def __le__(self, o): return self._bin("<=", o)             # noqa: E704
    def __gt__(self, o): return self._bin(">", o)              # noqa: E704
    def __ge__(self, o): return self._bin(">=", o)             # noqa: E704

    def __neg__(self):
        return CExpr(f"(-{self.text})")

    def __bool__(self):
        raise TypeError("a law formula branches on a C expression: use ops.where")

    def call(self, fn: str) -> CExpr:
        """`fn`(self) in C."""
        return CExpr(f"{fn}({self.text})")


def _kind(*xs):
    """"esym", "sympy" or "float": the backend of the arguments."""
    if any(isinstance(x, CExpr) for x in xs):
        return "c"
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
    if kind == "c":
        return x.call("sqrt")
    if kind == "esym":
        return _esym().sqrt(x)
    if kind == "sympy":
        import sympy

        return sympy.sqrt(x)
    return math.sqrt(x)


def exp(x):
    """Exponential."""
    kind = _kind(x)
    if kind == "c":
        return x.call("exp")
    if kind == "esym":
        return _esym().exp(x)
    if kind == "sympy":
        import sympy

        return sympy.exp(x)
    return math.exp(x)


def fabs(x):
    """Absolute value (sympy: a Piecewise, so that its derivative is +-1, not sign(x))."""
    kind = _kind(x)
    if kind == "c":
        return x.call("fabs")
    if kind == "esym":
        return _esym().abs(x)
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((x, x >= 0), (-x, True))
    return abs(x)


def sign(x):
    """1 for x > 0, else -1 (Exudyn's sign, 0 at x = 0: laws use it only where x != 0)."""
    kind = _kind(x)
    if kind == "c":
        return CExpr(f"({x.text} > 0.0 ? 1.0 : -1.0)")
    if kind == "esym":
        return _esym().sign(x)
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((1, x > 0), (-1, True))
    return 1.0 if x > 0.0 else -1.0


def where(condition, a, b):
    """a where `condition` holds, else b."""
    kind = _kind(condition, a, b)
    if kind == "c":
        return CExpr(f"({CExpr.of(condition)} ? {CExpr.of(a)} : {CExpr.of(b)})")
    if kind == "esym":
        esym = _esym()
        wrap = [v if _kind(v) == "esym" else esym.Real(float(v)) for v in (a, b)]
        return esym.IfThenElse(condition, wrap[0], wrap[1])
    if kind == "sympy":
        import sympy

        return sympy.Piecewise((a, condition), (b, True))
    return a if condition else b
