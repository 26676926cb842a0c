"""Planar kinematics of body frames on arrays of samples: a body-frame vector turned into the
world, and the minimal coordinates of a description (`Linkage.coordinates`) from its bodies'
frames, shared by the backends that compute absolute body states (Exudyn, ideal joints)."""

from __future__ import annotations

import math

import numpy as np

from ..model.linkage import GROUND, Linkage, Prismatic

__all__ = ["turn", "perp", "coordinate_series"]


def turn(phi, xy):
    """A(phi) xy for arrays of angles `phi` (n,) and a body-frame vector `xy`: (n, 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]], axis=-1)


def perp(v):
    """v turned by +90 degrees (the derivative of A(phi) xy by phi is perp(A(phi) xy))."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def coordinate_series(linkage: Linkage, q: dict, v: dict, a: dict):
    """The minimal coordinates, rates and accelerations by `Linkage.coordinates` name
    (absolute angles, floating bodies' positions, a prismatic joint's s along its axis) of
    the bodies' frames: `q`, `v`, `a` map each body to its (x, y, angle) series (s, 3) and
    their rates and accelerations (m, rad, per s, per s^2)."""
    points = {GROUND: linkage.ground_points, **{b.name: b.points for b in linkage.bodies}}
    zero = np.zeros_like(next(iter(q.values())))
    q, v, a = ({GROUND: zero, **arr} for arr in (q, v, a))

    def point(body, name):
        """Position, velocity, acceleration (s, 2) of point `name` of `body`."""
        w, al = v[body][:, 2], a[body][:, 2]
        r = turn(q[body][:, 2], points[body][name])
        return (q[body][:, :2] + r, v[body][:, :2] + perp(r) * w[:, None],
                a[body][:, :2] + perp(r) * al[:, None] - r * (w * w)[:, None])

    joints = {j.name: j for j in linkage.joints}
    coords, rates, accs = {}, {}, {}
    for c in linkage.coordinates():
        owner, what = c.rsplit(".", 1)
        if what in ("x", "y", "angle"):
            k = ("x", "y", "angle").index(what)
            coords[c], rates[c], accs[c] = q[owner][:, k], v[owner][:, k], a[owner][:, k]
            continue
        jt: Prismatic = joints[owner]                   # s along the axis
        (pa, va, aa), (pb, vb, ab) = point(jt.body_a, jt.point_a), point(jt.body_b, jt.point_b)
        w, al = v[jt.body_a][:, 2], a[jt.body_a][:, 2]
        u = turn(q[jt.body_a][:, 2], (math.cos(jt.angle), math.sin(jt.angle)))
        d, dv, da = pb - pa, vb - va, ab - aa
        along, across = np.sum(d * u, axis=1), np.sum(d * perp(u), axis=1)
        coords[c] = along
        rates[c] = np.sum(dv * u, axis=1) + w * across
        accs[c] = (np.sum(da * u, axis=1) + 2.0 * w * np.sum(dv * perp(u), axis=1)
                   + al * across - w * w * along)
    return coords, rates, accs
