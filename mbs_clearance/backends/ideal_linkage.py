"""Any description with ideal joints: every clearance joint closed (backend "ideal").

The same bodies, points, drive and gravity as the description, with every revolute clearance
joint an ideal pin (journal point on bearing point) and every translational clearance joint
an ideal prismatic joint (slider centre on the guide's mid-line, its axis along it): the
limit of the clearance model as the clearances go to zero. Friction and lubrication act in
the clearance only and have no ideal counterpart.

The model is written in absolute coordinates (x, y, angle of each body's centre of mass)
with the joints as algebraic constraints Phi(q, t) = 0 (the ideal joints may close loops
here, unlike the clearance model's ODE):

- a driven linkage whose constraints fix every coordinate (the four-bar, the slider-cranks)
  is kinematics: positions by Newton's method on Phi = 0 at every sample (continued along
  the drive from the centred assembly, to round-off), velocities and accelerations from the
  differentiated constraints, joint forces and the drive moment from Newton-Euler, all
  without integration error;
- any other linkage (free, or with more freedom than the drive) integrates
  M q'' + Phi_q^T lambda = Q, Phi_q q'' = gamma (Baumgarte-stabilised, DOP853 at `rtol`),
  each sample then projected on the constraints, from the start the clearance model takes
  (the centred assembly; a free linkage's `Initial`).

Reactions are forces ON the ground (as `Trajectory.reactions`); ``contact_force`` holds
each clearance joint's ideal reaction magnitude (what the clearance model's contact force
tends to in permanent contact; a translational joint's corners: the normal force split
between the slider's ends), with no penetration and contact throughout.
"""

from __future__ import annotations

import math

import numpy as np

from .._checks import MemoryLimitError, check_int, check_max_memory, check_real, format_bytes
from ..elements.registry import elements_with
from ..model.linkage import GROUND, Linkage, Revolute
from .kinematics import coordinate_series, perp, turn

__all__ = ["simulate_ideal_linkage", "peak_ideal_linkage", "IdealModel"]

#: the elements whose ideal joint this backend builds (`elements.registry`)
_ELEMENTS = elements_with("ideal joint")

#: options of `simulate(linkage, backend="ideal")`
OPTION_NAMES = ("samples_per_revolution", "max_memory", "duration", "window", "rtol")

#: peak bytes per sample: the states, the constraint Jacobians and the series of the record
#: (about 40 floats per coordinate of a three-body linkage), with a margin
BYTES_PER_COORDINATE_SAMPLE = 8 * 60

#: samples per drive revolution (a free linkage: per time scale) of the coarse continuation
#: whose positions start Newton's method at every sample
CONTINUATION_STEPS = 36


class IdealModel:
    """The constraints of a `Linkage` with every joint ideal, in absolute coordinates.

    Body k (0 is the ground, then the description's bodies in order) has the coordinates
    3 (k - 1) ... 3 (k - 1) + 2 of a state (x, y, angle). Rows, in order: each ideal joint
    (a revolute: 2, a prismatic: the offset across its axis and the angle between the
    bodies), each element's joint as its ideal joint (`Element.ideal_joints`: a revolute
    clearance joint's pin, 2; a translational clearance joint's prismatic, 2), the drive (1).
    """

    def __init__(self, linkage: Linkage, angles: dict[str, float]):
        self.linkage = linkage
        names = [b.name for b in linkage.bodies]
        self.body = {GROUND: 0, **{n: k + 1 for k, n in enumerate(names)}}
        self.n = 3 * len(names)
        self.mass = np.array([[b.mass, b.mass, b.inertia] for b in linkage.bodies]).ravel()
        points = {GROUND: linkage.ground_points, **{b.name: b.points for b in linkage.bodies}}
        #: (kind, joint, data) per constraint group; `rows[joint]` its rows
        self.items: list[tuple[str, str, tuple]] = []
        self.rows: dict[str, list[int]] = {}

        def add(kind, joint, data, count):
            start = sum(len(r) for r in self.rows.values())
            self.rows.setdefault(joint, []).extend(range(start, start + count))
            self.items.append((kind, joint, data))

        def pin(name, a, pa, b, pb):
            add("pin", name, (self.body[a], points[a][pa], self.body[b], points[b][pb]), 2)

        def slide(name, a, pa, angle, b, pb, offset):
            normal = (-math.sin(angle), math.cos(angle))
            add("slide", name, (self.body[a], points[a][pa], normal, self.body[b],
                                points[b][pb]), 1)
            add("angle", name, (self.body[a], self.body[b], offset), 1)

        for j in linkage.joints:
            if isinstance(j, Revolute):
                pin(j.name, j.body_a, j.point_a, j.body_b, j.point_b)
            else:
                slide(j.name, j.body_a, j.point_a, j.angle, j.body_b, j.point_b,
                      angles.get(j.body_b, 0.0) - angles.get(j.body_a, 0.0))
        closers = {"pin": pin, "slide": slide}
        for el in _ELEMENTS:
            for kind, args in el.ideal_joints(linkage, angles):
                closers[kind](*args)
        self.drive_row = None
        if linkage.drive is not None:
            crank = next(j.body_b for j in linkage.joints if j.name == linkage.drive.joint)
            add("drive", "drive", (self.body[crank],), 1)
            self.drive_row = self.rows["drive"][0]
        self.m = sum(len(r) for r in self.rows.values())

    # -------------------------------------------------------------- constraint functions
    def _frames(self, q):
        """(x, y, angle) arrays (n,) per body index, the ground's zeros included."""
        zero = np.zeros(q.shape[0])
        frames = [(zero, zero, zero)]
        for k in range(self.n // 3):
            frames.append((q[:, 3 * k], q[:, 3 * k + 1], q[:, 3 * k + 2]))
        return frames

    def evaluate(self, q, qd, t):
        """Phi (s, m), Phi_q over the ground's and the bodies' coordinates (s, m, n + 3),
        and gamma (s, m), the right-hand side of Phi_q q'' = gamma, for states `q`, `qd`
        (s, n) at times `t` (s,)."""
        s = q.shape[0]
        pose = self._frames(q)
        rate = self._frames(qd)
        phi = np.zeros((s, self.m))
        jac = np.zeros((s, self.m, self.n + 3))
        gamma = np.zeros((s, self.m))
        row = 0
        for kind, _, data in self.items:
            if kind == "pin":
                i, si, j, sj = data
                ri, rj = turn(pose[i][2], si), turn(pose[j][2], sj)
                wi, wj = rate[i][2], rate[j][2]
                for k in range(2):
                    phi[:, row + k] = (pose[i][k] + ri[:, k]) - (pose[j][k] + rj[:, k])
                    jac[:, row + k, 3 * i + k] += 1.0
                    jac[:, row + k, 3 * j + k] -= 1.0
                jac[:, row:row + 2, 3 * i + 2] += perp(ri)
                jac[:, row:row + 2, 3 * j + 2] -= perp(rj)
                gamma[:, row:row + 2] = ri * (wi**2)[:, None] - rj * (wj**2)[:, None]
                row += 2
            elif kind == "slide":
                a, sa, n0, b, sb = data
                ra, rb = turn(pose[a][2], sa), turn(pose[b][2], sb)
                n = turn(pose[a][2], n0)
                d = (np.stack([pose[b][0], pose[b][1]], axis=-1) + rb
                     - np.stack([pose[a][0], pose[a][1]], axis=-1) - ra)
                wa, wb = rate[a][2], rate[b][2]
                dd = (np.stack([rate[b][0], rate[b][1]], axis=-1) + perp(rb) * wb[:, None]
                      - np.stack([rate[a][0], rate[a][1]], axis=-1) - perp(ra) * wa[:, None])
                nd = perp(n) * wa[:, None]
                phi[:, row] = np.sum(n * d, axis=1)
                jac[:, row, 3 * a:3 * a + 2] -= n
                jac[:, row, 3 * b:3 * b + 2] += n
                jac[:, row, 3 * b + 2] += np.sum(n * perp(rb), axis=1)
                jac[:, row, 3 * a + 2] += (np.sum(perp(n) * d, axis=1)
                                           - np.sum(n * perp(ra), axis=1))
                gamma[:, row] = -(-(wa**2) * np.sum(n * d, axis=1) + 2.0 * np.sum(nd * dd, axis=1)
                                  + np.sum(n * (ra * (wa**2)[:, None] - rb * (wb**2)[:, None]),
                                           axis=1))
                row += 1
            elif kind == "angle":
                a, b, offset = data
                phi[:, row] = pose[b][2] - pose[a][2] - offset
                jac[:, row, 3 * a + 2] -= 1.0
                jac[:, row, 3 * b + 2] += 1.0
                row += 1
            else:                                       # the drive
                (crank,) = data
                drive = self.linkage.drive
                phi[:, row] = pose[crank][2] - (drive.speed * t + drive.initial_angle)
                jac[:, row, 3 * crank + 2] = 1.0
                row += 1
        return phi, jac, gamma

    def velocity_rhs(self, s: int) -> np.ndarray:
        """-Phi_t (s, m): the drive's speed on its row, zero elsewhere."""
        out = np.zeros((s, self.m))
        if self.drive_row is not None:
            out[:, self.drive_row] = self.linkage.drive.speed
        return out

    # ------------------------------------------------------------------ solutions
    def dynamics(self, q, qd, t, stabilise: float = 0.0):
        """Accelerations (s, n), multipliers (s, m) and the constraint Jacobian over every
        coordinate, the ground's first (s, m, n + 3), at states (q, qd) and times t (the
        constraints' drift damped at the rate `stabilise` in 1/s, Baumgarte)."""
        s = q.shape[0]
        phi, jac_all, gamma = self.evaluate(q, qd, t)
        jac = jac_all[:, :, 3:]
        if stabilise:
            drift = np.einsum("smn,sn->sm", jac, qd) - self.velocity_rhs(s)
            gamma = gamma - 2.0 * stabilise * drift - stabilise**2 * phi
        size = self.n + self.m
        kkt = np.zeros((s, size, size))
        kkt[:, :self.n, :self.n] = np.diag(self.mass)
        kkt[:, :self.n, self.n:] = np.transpose(jac, (0, 2, 1))
        kkt[:, self.n:, :self.n] = jac
        forces = np.zeros((s, self.n))
        forces[:, 1::3] = -self.mass[1::3] * self.linkage.gravity
        rhs = np.concatenate([forces, gamma], axis=1)
        sol = _solve(kkt, rhs)
        return sol[:, :self.n], sol[:, self.n:], jac_all

    def project(self, q, qd, t, tol: float, max_iter: int = 20):
        """(q, qd) moved onto the constraints at times t: Newton (minimum-norm steps) on
        Phi = 0 to `tol` (m) and one step more (quadratic convergence: to round-off), then
        the velocities' minimum-norm correction."""
        for _ in range(max_iter):
            phi, jac, _ = self.evaluate(q, qd, t)
            done = np.max(np.abs(phi)) <= tol
            q = q - _min_norm(jac[:, :, 3:], phi)
            if done:
                break
        else:
            raise RuntimeError(f"the ideal joints of linkage {self.linkage.name!r} cannot "
                               f"be closed (residual {np.max(np.abs(phi)):.3g} m after "
                               f"{max_iter} Newton steps): the linkage locks or changes "
                               "branch at a dead point")
        _, jac, _ = self.evaluate(q, qd, t)
        jac = jac[:, :, 3:]
        residual = np.einsum("smn,sn->sm", jac, qd) - self.velocity_rhs(q.shape[0])
        return q, qd - _min_norm(jac, residual)


def _solve(matrix, rhs):
    """matrix x = rhs for stacks; least squares (minimum norm) where a stack is singular
    (redundant constraints: their multipliers are then not unique)."""
    try:
        return np.linalg.solve(matrix, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.einsum("sij,sj->si", np.linalg.pinv(matrix), rhs)


def _min_norm(jac, residual):
    """The minimum-norm x of jac x = residual per stack: jac^T (jac jac^T)^-1 residual
    (the pseudo-inverse where the rows are dependent: redundant constraints)."""
    try:
        if jac.shape[1] == jac.shape[2]:
            return np.linalg.solve(jac, residual[..., None])[..., 0]
        y = np.linalg.solve(jac @ np.transpose(jac, (0, 2, 1)), residual[..., None])
        return (np.transpose(jac, (0, 2, 1)) @ y)[..., 0]
    except np.linalg.LinAlgError:
        return np.einsum("snm,sm->sn", np.linalg.pinv(jac), residual)


def _tree_start(linkage: Linkage) -> tuple[dict, dict]:
    """The clearance model's start in its own coordinates: the centred assembly (a free
    linkage's given coordinates held) and rates solving the velocity closure with minimum
    norm (a free linkage's given rates held)."""
    names = linkage.coordinates()
    q = linkage.assemble()
    given = {} if linkage.drive is not None else dict(linkage.start.rates)
    x = np.array([q[c] for c in names])
    scale = max(linkage.length_scale, 1e-300)
    steps = np.array([1e-6 if c.endswith(".angle") else 1e-6 * scale for c in names])

    def gaps(v, t=0.0):
        return np.array(linkage.gaps(dict(zip(names, v.tolist())), t))

    jac = np.column_stack([(gaps(x + np.eye(len(x))[i] * h) - gaps(x - np.eye(len(x))[i] * h))
                           / (2.0 * h) for i, h in enumerate(steps)])
    rate_t = np.zeros(jac.shape[0])
    if linkage.drive is not None:
        h = 1e-6 / linkage.drive.speed
        rate_t = (gaps(x, h) - gaps(x, -h)) / (2.0 * h)
    u = np.array([given.get(c, 0.0) for c in names])
    solve = np.array([c not in given for c in names])
    if solve.any():
        rhs = -rate_t - jac[:, ~solve] @ u[~solve]
        u[solve] = np.linalg.lstsq(jac[:, solve], rhs, rcond=None)[0]
    return q, dict(zip(names, u.tolist()))


def _absolute(linkage: Linkage, q: dict, u: dict) -> tuple[np.ndarray, np.ndarray]:
    """Absolute coordinates and their rates of the tree coordinates `q` and rates `u` (the
    rates by central differences along u of `Linkage.poses`, corrected by the projection)."""
    names = [b.name for b in linkage.bodies]
    h = 1e-6 * linkage.time_scale

    def frames(sign):
        moved = {c: v + sign * h * u[c] for c, v in q.items()}
        poses = linkage.poses(moved, sign * h)
        return np.array([poses[n] for n in names]).ravel()

    return frames(0.0), (frames(1.0) - frames(-1.0)) / (2.0 * h)


def _span(linkage: Linkage, revolutions, options: dict):
    """(times, the `Span`, samples per revolution) of a run (`linkage_model.prepare_span`:
    drive revolutions, or a free linkage's time windows); ValueError before any work for a
    bad count, option or size."""
    from ..solve.linkage_model import prepare_span

    unknown = sorted(set(options) - set(OPTION_NAMES))
    if unknown:
        raise ValueError(f"unknown option(s) {unknown} for backend 'ideal'; allowed: "
                         f"{sorted(OPTION_NAMES)}")
    duration, window = options.get("duration"), options.get("window")
    per = check_int("samples_per_revolution", options.get("samples_per_revolution", 3600), 8)
    max_memory = check_max_memory(options.get("max_memory"))
    span = prepare_span(linkage, revolutions, duration=duration, window=window,
                        max_memory=max_memory)
    if span.revolutions is None:
        n = max(int(math.ceil(span.duration / linkage.time_scale * per)), 8) + 1
    else:
        n = span.revolutions * per + 1
    need = n * (3 * len(linkage.bodies) + 3) * BYTES_PER_COORDINATE_SAMPLE
    if need > max_memory:
        raise MemoryLimitError(
            f"{n} samples of the ideal-joint run need about {format_bytes(need)}, more than "
            f"max_memory={max_memory} bytes ({format_bytes(max_memory)}); use fewer "
            "samples_per_revolution or a shorter run, or raise max_memory")
    return np.linspace(0.0, float(span.edges[-1]), n), span, per


def _fixed_by_constraints(model: IdealModel, q0: np.ndarray) -> bool:
    """Whether the constraints fix every coordinate (no freedom beside the drive)."""
    _, jac, _ = model.evaluate(q0[None], np.zeros((1, model.n)), np.zeros(1))
    return (model.linkage.drive is not None
            and np.linalg.matrix_rank(jac[0, :, 3:]) == model.n)


def _kinematics(model: IdealModel, q0, t, tol):
    """Positions and velocities at the times `t` of a linkage the constraints fix: a coarse
    continuation along the drive from the assembly `q0`, Hermite guesses at every sample,
    then Newton's method at all samples at once."""
    period = model.linkage.period
    coarse = np.linspace(0.0, t[-1], max(int(round(t[-1] / period * CONTINUATION_STEPS)), 2)
                         + 1)
    qs, vs = np.empty((len(coarse), model.n)), np.empty((len(coarse), model.n))
    q = q0[None].copy()
    v = np.zeros((1, model.n))
    for k, tk in enumerate(coarse):
        if k:
            dt = tk - coarse[k - 1]
            acc, _, _ = model.dynamics(q, v, np.array([coarse[k - 1]]))
            q = q + v * dt + 0.5 * acc * dt**2
        q, v = model.project(q, v, np.array([tk]), tol)
        qs[k], vs[k] = q[0], v[0]
    # cubic Hermite between the continuation's points: guesses within Newton's reach
    k = np.clip(np.searchsorted(coarse, t, side="right") - 1, 0, len(coarse) - 2)
    h = coarse[k + 1] - coarse[k]
    x = ((t - coarse[k]) / h)[:, None]
    guess = ((2 * x**3 - 3 * x**2 + 1) * qs[k] + (x**3 - 2 * x**2 + x) * h[:, None] * vs[k]
             + (-2 * x**3 + 3 * x**2) * qs[k + 1] + (x**3 - x**2) * h[:, None] * vs[k + 1])
    return model.project(guess, np.zeros_like(guess), t, tol)


def _integrate(model: IdealModel, q0, v0, t, rtol, tol):
    """Positions and velocities at the times `t` of a linkage with freedom left: the
    Baumgarte-stabilised equations integrated by DOP853 from (q0, v0), each sample projected
    on the constraints."""
    from scipy.integrate import solve_ivp

    rate = model.linkage.rate_scale
    n = model.n

    def rhs(time, y):
        acc, _, _ = model.dynamics(y[None, :n], y[None, n:], np.array([time]), rate)
        return np.concatenate([y[n:], acc[0]])

    scale = np.concatenate([np.full(n, model.linkage.length_scale), np.full(n, 1.0)])
    sol = solve_ivp(rhs, (t[0], t[-1]), np.concatenate([q0, v0]), method="DOP853",
                    t_eval=t, rtol=rtol, atol=rtol * scale * 1e-3)
    if not sol.success:
        raise RuntimeError(f"the ideal-joint run of linkage {model.linkage.name!r} failed: "
                           f"{sol.message}")
    return model.project(sol.y[:n].T, sol.y[n:].T, t, tol)


def simulate_ideal_linkage(linkage: Linkage, revolutions: int | None = None, **options):
    """`linkage` with every joint ideal (module docstring): a `Trajectory` of the same form as
    the clearance model's, sampled uniformly. The paper's case (a linkage of its parameter
    set, `design.slider_crank_of`) runs its closed form, `ideal.simulate_ideal`, as the
    `SliderCrank` does.

    Parameters
    ----------
    linkage : Linkage
        Any description, driven or free.
    revolutions : int or None
        Drive revolutions (default 4); a free linkage takes ``duration`` (s) and ``window``
        (s) as options instead.
    **options
        ``samples_per_revolution`` (default 3600; a free linkage: per time scale,
        `Linkage.time_scale`), ``rtol`` (default 1e-10: the integrated runs only),
        ``duration``, ``window``, ``max_memory`` (bytes).

    Returns
    -------
    Trajectory
        ``base_force`` the monitored ground joint's reaction (N, the shaking force when
        none is monitored), ``crank_moment`` the drive moment (N m; None for a free
        linkage), ``reactions`` every ground joint's force on the ground (N),
        ``contact_force`` each contact's ideal reaction magnitude (N), ``coordinates``,
        ``rates``, ``accelerations`` by `Linkage.coordinates` name; ``peaks`` the monitored
        force's maximum per revolution (per window) refined between samples;
        ``stats["constraint_residual"]`` the largest constraint residual (m),
        ``stats["integrated"]`` whether the run integrated (freedom left) or solved the
        kinematics.
    """
    from ..model.design import slider_crank_of

    paper = slider_crank_of(linkage)
    if paper is not None:       # the paper's parameter set: its closed form, as before
        from .ideal import simulate_ideal

        _, span, _ = _span(linkage, revolutions, options)     # the same checks
        closed_form = {k: v for k, v in options.items()
                       if k in ("samples_per_revolution", "max_memory")}   # no integration
        return simulate_ideal(paper, span.revolutions, **closed_form)
    return constrained_run(linkage, revolutions, **options)


def constrained_run(linkage: Linkage, revolutions: int | None = None, **options):
    """`simulate_ideal_linkage` by the constraints alone (module docstring), also for the
    paper's case (whose backend run is its closed form)."""
    from ..solve.trajectory import Trajectory, annotate
    from .exudyn_linkage import window_peaks

    options = dict(options)
    t, span, per = _span(linkage, revolutions, options)
    rtol = check_real("rtol", options.get("rtol", 1e-10), 1e-14, 1e-3)
    q_tree, u_tree = _tree_start(linkage)
    q0, v0 = _absolute(linkage, q_tree, u_tree)
    angles = {b.name: q0[3 * k + 2] for k, b in enumerate(linkage.bodies)}
    model = IdealModel(linkage, angles)
    tol = 1e-12 * max(linkage.length_scale, 1e-300)
    q0, v0 = (a[0] for a in model.project(q0[None], v0[None], np.zeros(1), tol))
    integrated = not _fixed_by_constraints(model, q0)
    if integrated:
        q, v = _integrate(model, q0, v0, t, rtol, tol)
    else:
        q, v = _kinematics(model, q0, t, tol)
    acc, lam, jac = model.dynamics(q, v, t)
    phi, _, _ = model.evaluate(q, v, t)

    def force_on_ground(joint):
        rows = model.rows[joint]
        return -np.einsum("srk,sr->sk", jac[:, rows, 0:2], lam[:, rows])

    reactions = {g: force_on_ground(g) for g in linkage.ground_joints()}
    shaking = sum(reactions.values())
    monitored = shaking if linkage.monitor_joint is None else reactions[linkage.monitor_joint]
    magnitude = np.hypot(monitored[:, 0], monitored[:, 1])
    contact = []
    for el in _ELEMENTS:
        contact += el.ideal_contact_forces(linkage, lambda name: lam[:, model.rows[name]])
    contact = np.column_stack(contact)
    moment = work = None
    if span.revolutions is not None:
        moment = -lam[:, model.drive_row]
        power = moment * linkage.drive.speed
        work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    coords, rates, accs = _tree_series(linkage, q, v, acc)
    contacts = linkage.contacts()
    stats = {"samples_per_revolution": per, "integrated": integrated,
             "constraint_residual": float(np.max(np.abs(phi)))}
    if integrated:
        stats["rtol"] = rtol
    peaks = window_peaks(t, magnitude, span.windows)
    return annotate(Trajectory(
        t=t, base_force=np.ascontiguousarray(monitored), crank_moment=moment,
        contact_force=contact, penetration=np.zeros_like(contact),
        eccentricity=np.zeros((len(t), len(contacts), 2)),
        contact_phase=np.ones(contact.shape, dtype=np.int8), crank_work=work,
        mechanism=linkage, backend="ideal", stats=stats, peaks=peaks,
        joints=tuple(name for name, _ in contacts), reactions=reactions,
        shaking_force=np.ascontiguousarray(shaking), coordinates=coords, rates=rates,
        accelerations=accs))


def _tree_series(linkage: Linkage, q, v, a):
    """`coordinate_series` of the absolute states (s, n) of an `IdealModel`."""
    names = [b.name for b in linkage.bodies]
    return coordinate_series(linkage, *({n: arr[:, 3 * k:3 * k + 3] for k, n in
                                         enumerate(names)} for arr in (q, v, a)))


def peak_ideal_linkage(linkage: Linkage, revolution: int | None = None, **options) -> float:
    """Max of the monitored force in N over drive revolution `revolution` (1-based, default
    4) of the ideal-joint linkage; a free linkage: over the last window of a run of
    ``duration`` s (windows of ``window`` s)."""
    traj = simulate_ideal_linkage(linkage, revolution, **options)
    return float(traj.peaks[-1])
