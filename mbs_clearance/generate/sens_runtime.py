"""The layout of a sensitivity run's parameter vector and work space (the compiled model's
core/sens_runtime.h reads it; `linkage_ddm` and `c_loader` write it).

Sensitivity state (DDM): y = [q, qdot (2 N_Q), s_1 ... s_nb (2 N_Q each), W, sigma], where
s_k = d(q, qdot)/db_k for the integrated directions k and sigma[k J + j] = d(impact velocity
of joint j)/db_k (constant between events: its derivative is zero, the event sets it).
The parameter vector of a sensitivity run is the model's p (N_P entries), then a header at
N_P: [nb, event-time term flag, m], the sparse chain D (per direction k, m columns of z and
m values: dp/db_k), then work space (the Jacobian, N_JROWS (N_Z + 1); the plain monitor's
derivative, 2 N_Q + 1).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ddm_layout", "work_offsets", "work_size", "seed_index", "fill_seed_work"]


def ddm_layout(p, n_p):
    """(nb, m, first column entry, first value entry, work start) of a sensitivity run's p."""
    nb_ = int(p[n_p])
    m = int(p[n_p + 2])
    c0 = n_p + 3
    v0 = c0 + nb_ * m
    return nb_, m, c0, v0, v0 + nb_ * m


def work_offsets(nb_, w0, nz, n_jrows, n_joints):
    """Starts of the work space's parts: the Jacobian (n_jrows (nz + 1)), the seeds
    (nb nz), which seeds use each column (`seed_index`: nz + 1 + nb nz), the chain's part
    of the seeds at the memories' columns (nb J), the tangents (n_jrows (nb + 1)), the
    plain monitor's derivative."""
    dz0 = w0 + n_jrows * (nz + 1)
    use0 = dz0 + nb_ * nz
    mb0 = use0 + nz + 1 + nb_ * nz
    t0 = mb0 + nb_ * n_joints
    return dz0, use0, mb0, t0, t0 + n_jrows * (nb_ + 1)


def work_size(nb_: int, nz: int, n_jrows: int, n_q: int, n_joints: int) -> int:
    """Entries of a sensitivity run's work space (see `work_offsets`)."""
    return (n_jrows * (nz + 1) + nb_ * nz + nz + 1 + nb_ * nz + nb_ * n_joints
            + n_jrows * (nb_ + 1) + 2 * n_q + 1)


def seed_index(nonzero, use):
    """Which seeds use each column of z, as the compiled `tangent` reads it: for column k
    the seeds use[nz + 1 + e], e in [use[k], use[k + 1]) (nonzero: (nd, nz) booleans)."""
    nonzero = np.asarray(nonzero, dtype=bool)
    nz = nonzero.shape[1]
    counts = nonzero.sum(axis=0)
    use[:nz] = np.cumsum(counts) - counts
    use[nz] = counts.sum()
    # the seeds column by column, in increasing order within a column
    _, seeds = np.nonzero(nonzero.T)
    use[nz + 1:nz + 1 + seeds.shape[0]] = seeds


def fill_seed_work(work, entries, nz: int, n_jrows: int, n_q: int, mem_col0: int,
                   n_joints: int):
    """The constant part of the seeds in a sensitivity run's work space (laid out as
    `work_offsets` with w0 = 0): the chains D_k (entries[k]: {column of z: value}) into the
    seeds' parameter columns, the columns used, and the chains' values at the memories'
    columns (the compiled model adds sigma_k there in each call)."""
    nb_ = len(entries)
    dz0, use0, mb0, _, _ = work_offsets(nb_, 0, nz, n_jrows, n_joints)
    nonzero = np.zeros((nb_, nz), dtype=np.bool_)
    nonzero[:, 1:1 + 2 * n_q] = True
    mem_cols = [mem_col0 + 2 * j for j in range(n_joints)]
    nonzero[:, mem_cols] = True
    for k, ent in enumerate(entries):
        for c, v in ent.items():
            work[dz0 + k * nz + c] += v
            nonzero[k, c] = True
        for j, c in enumerate(mem_cols):
            work[mb0 + k * n_joints + j] = work[dz0 + k * nz + c]
    seed_index(nonzero, work[use0:mb0])
