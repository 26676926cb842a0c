"""The film laws against the numerical finite bearing: the measurements of
docs/lubrication.md ("The independent check", "Where each applies", "Where the classical
short-bearing forms disagree").

    python -m validation.film_checks

A journal of radius 10 mm in a clearance of 10 um, oil of 10 mPa s; the numerical film is
`validation.reynolds.solve` (half-Sommerfeld unless stated). Relative differences are of
the force vectors. The motions: the wedge alone (the journal turning; journal and bearing
turning), the squeeze alone (approaching, separating at 1 mm/s) and both with whirl, the
same as tests/unit/test_lubrication.py's, which asserts bounds on the same quantities.
"""

from __future__ import annotations

import math

import numpy as np

from mbs_clearance.laws.lubrication import long_bearing, short_bearing
from validation.reynolds import solve

#: journal radius (m), radial clearance (m), viscosity (Pa s)
R, C, MU = 0.01, 1e-5, 0.01
#: the direction of the eccentricity (any: the laws are frame-free)
DIRECTION = 0.7
MOTIONS = {
    "wedge": dict(omega_j=300.0),
    "wedge_bearing": dict(omega_j=100.0, omega_b=-200.0),
    "squeeze_in": dict(radial_rate=1e-3),
    "squeeze_out": dict(radial_rate=-1e-3),
    "combined_in": dict(radial_rate=1e-3, tangential_rate=2e-4, omega_j=300.0, omega_b=50.0),
    "combined_out": dict(radial_rate=-1e-3, tangential_rate=-3e-4, omega_j=300.0),
}


def state(eps, radial_rate=0.0, tangential_rate=0.0, omega_j=0.0, omega_b=0.0):
    """(ex, ey, vx, vy, omega_j, omega_b): e at DIRECTION, its rate along u_r and u_t."""
    ux, uy = math.cos(DIRECTION), math.sin(DIRECTION)
    return (eps * C * ux, eps * C * uy,
            radial_rate * ux - tangential_rate * uy, radial_rate * uy + tangential_rate * ux,
            omega_j, omega_b)


def rel(num, ref) -> float:
    return math.hypot(num[0] - ref[0], num[1] - ref[1]) / math.hypot(ref[0], ref[1])


def _span(values, fmt="{:.2g}") -> str:
    lo, hi = fmt.format(min(values)), fmt.format(max(values))
    return lo if lo == hi else f"{lo}-{hi}"


def _force(sol):
    return sol.fx, sol.fy


def grid() -> str:
    s = state(0.6, **MOTIONS["combined_in"])
    L = 0.05 * 2 * R
    f = [_force(solve(*s, R, C, L, MU, n_theta=n, n_z=n // 6)) for n in (60, 120, 240, 480)]
    d = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(f, f[1:])]
    return (f"grid, 60 -> 480 nodes around: successive differences fall by "
            f"{d[0] / d[1]:.1f} and {d[1] / d[2]:.1f}")


def short_limit() -> list[str]:
    rows = ["| eps | L/D = 0.1 | 0.05 | 0.025 |", "|---|---|---|---|"]
    for eps in (0.2, 0.5, 0.8):
        cells = []
        for ld in (0.1, 0.05, 0.025):
            L = ld * 2 * R
            errs = [100 * rel(_force(solve(*state(eps, **m), R, C, L, MU, n_theta=240, n_z=40)),
                              short_bearing(*state(eps, **m), R, C, L, MU))
                    for m in MOTIONS.values()]
            cells.append(_span(errs) + " %")
        rows.append(f"| {eps} | " + " | ".join(cells) + " |")
    return rows


def _long_gain(s, ld, n_theta, per_diameter=5):
    a = solve(*s, R, C, ld * 2 * R, MU, n_theta=n_theta, n_z=int(per_diameter * ld))
    b = solve(*s, R, C, 2 * ld * 2 * R, MU, n_theta=n_theta, n_z=int(2 * per_diameter * ld))
    return b.fx - a.fx, b.fy - a.fy, a


def long_limit() -> list[str]:
    short_by, gain = [], []
    for eps in (0.2, 0.5, 0.8):
        for m in MOTIONS.values():
            s = state(eps, **m)
            ref = long_bearing(*s, R, C, 10 * 2 * R, MU)
            fx, fy, finite = _long_gain(s, 10, 240)
            short_by.append(100 * (1 - math.hypot(finite.fx, finite.fy) / math.hypot(*ref[:2])))
            gain.append(100 * rel((fx, fy), ref))
    rng = np.random.default_rng(7)
    random_states = []
    for _ in range(12):
        s = state(rng.uniform(0.05, 0.9), radial_rate=rng.uniform(-2e-3, 2e-3),
                  tangential_rate=rng.uniform(-1e-3, 1e-3),
                  omega_j=rng.uniform(-500, 500), omega_b=rng.uniform(-500, 500))
        fx, fy, _ = _long_gain(s, 10, 120)
        random_states.append(100 * rel((fx, fy), long_bearing(*s, R, C, 10 * 2 * R, MU)))
    return [f"long limit: L/D = 10 is {_span(short_by)} % short of the long law; "
            f"L/D 10 -> 20 adds the long law within {max(gain):.2g} % (every motion, 240 "
            f"around), within {max(random_states):.2g} % over 12 random combined states "
            "(120 around)"]


def full_film_squeeze(eps=0.5, rate=1e-3) -> tuple[float, float]:
    """The radial force (N) of a pure squeeze without cavitation in the numerical long limit
    (what lengthening L = 20 R to 40 R adds), and Sommerfeld's full-film
    F_r = -12 pi mu R^3 L eps_dot / (c^2 (1 - eps^2)^1.5) at L = 20 R."""
    s = state(eps, radial_rate=rate)
    a = solve(*s, R, C, 20 * R, MU, n_theta=120, n_z=50, cavitation="full")
    b = solve(*s, R, C, 40 * R, MU, n_theta=120, n_z=100, cavitation="full")
    fr = (b.fx - a.fx) * math.cos(DIRECTION) + (b.fy - a.fy) * math.sin(DIRECTION)
    ref = -12 * math.pi * MU * R**3 * (20 * R) * (rate / C) / (C**2 * (1 - eps**2) ** 1.5)
    return fr, ref


def full_film() -> str:
    fr, ref = full_film_squeeze()
    return f"full film, pure squeeze: Sommerfeld's F_r within {100 * abs(fr / ref - 1):.2g} %"


def where_each_applies() -> list[str]:
    rows = ["| L/D | eps | short / finite | long / finite |", "|---|---|---|---|"]
    for ld in (0.25, 0.5, 1.0):
        for eps in (0.5, 0.76):
            L = ld * 2 * R
            short, long_ = [], []
            for name in ("wedge", "squeeze_in", "combined_in"):
                s = state(eps, **MOTIONS[name])
                num = math.hypot(*_force(solve(*s, R, C, L, MU, n_theta=240, n_z=60)))
                short.append(math.hypot(*short_bearing(*s, R, C, L, MU)[:2]) / num)
                long_.append(math.hypot(*long_bearing(*s, R, C, L, MU)[:2]) / num)
            rows.append(f"| {ld} | {eps} | {_span(short, '{:.3g}')} | {_span(long_)} |")
    return rows


def classical_short(eps, eps_dot, omega_bar, L):
    """The classical short-bearing forms (both terms over (0, pi); Flores et al. 2006),
    (F_r, F_t) in the line-of-centres frame."""
    k = MU * R * L**3 / (2 * C**2)
    fr = -k * (2 * eps**2 * omega_bar / (1 - eps**2) ** 2
               + math.pi * (1 + 2 * eps**2) * eps_dot / (1 - eps**2) ** 2.5)
    ft = k * (math.pi * eps * omega_bar / (2 * (1 - eps**2) ** 1.5)
              + 4 * eps * eps_dot / (1 - eps**2) ** 2)
    return fr, ft


def frame(f):
    ux, uy = math.cos(DIRECTION), math.sin(DIRECTION)
    return f[0] * ux + f[1] * uy, -f[0] * uy + f[1] * ux


def classical() -> list[str]:
    rows = ["| eps | motion | numerical F_r (N) | law | classical F_r | classical F_t / |F_r| |",
            "|---|---|---|---|---|---|"]
    L = 0.025 * 2 * R
    for eps in (0.2, 0.5, 0.8):
        for rate, motion in ((1e-3, "approaching"), (-1e-3, "separating")):
            s = state(eps, radial_rate=rate)
            num = frame(_force(solve(*s, R, C, L, MU, n_theta=240, n_z=40)))
            law = frame(short_bearing(*s, R, C, L, MU))
            fr, ft = classical_short(eps, rate / C, 0.0, L)
            rows.append(f"| {eps} | {motion} | {num[0]:.3g} | {law[0]:.3g} | {fr:.3g} "
                        f"({100 * (fr / num[0] - 1):+.0f} %) | {100 * abs(ft / num[0]):.0f} % |")
    return rows


def combined_long_film() -> str:
    """The long law against the numerical long limit where the film both squeezes and
    turns (its positive region's ends move with both terms)."""
    s = state(0.6, radial_rate=-1e-3, tangential_rate=2e-4, omega_j=300.0)
    fx, fy, _ = _long_gain(s, 20, 240, per_diameter=10)
    law = long_bearing(*s, R, C, 20 * 2 * R, MU)
    return (f"long film, eps 0.6, separating, whirling and turning, L = 0.4 m: radial force "
            f"{frame((fx, fy))[0] / 1e3:.1f} kN numerical, {frame(law)[0] / 1e3:.1f} kN law")


def superposed_long_film() -> str:
    """The same state with the long film's wedge and squeeze terms each integrated over its
    own positive region (the law of each motion alone, summed: exact for each alone), the
    superposition the law does not use."""
    kw = dict(tangential_rate=2e-4, omega_j=300.0)
    wedge = long_bearing(*state(0.6, **kw), R, C, 20 * 2 * R, MU)
    squeeze = long_bearing(*state(0.6, radial_rate=-1e-3), R, C, 20 * 2 * R, MU)
    fr = frame((wedge[0] + squeeze[0], wedge[1] + squeeze[1]))[0]
    return (f"long film, the same state, the wedge's and the squeeze's terms each over its "
            f"own positive region: radial force {fr / 1e3:.1f} kN")


def main() -> None:
    print(grid())
    print("\n".join(short_limit()))
    print("\n".join(long_limit()))
    print(full_film())
    print("\n".join(where_each_applies()))
    print("\n".join(classical()))
    print(combined_long_film())
    print(superposed_long_film())


if __name__ == "__main__":
    main()
