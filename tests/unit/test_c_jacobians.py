"""The C core's Jacobian and tangent kernels (generate/cjacobians.py, core/jac_runtime.h):
against central differences of the C plain model's outputs (and in
tests/unit/test_generated_jacobians.py of every named case, with the tangents as the
Jacobian times the seeds), the oil film's partials in C against central differences of the
C film and against their Python twin (laws/lubrication/partials.py), the contact law's in C
against its Python formula; the statement translator on the plan's forms of line."""

import sys
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance.core import build
from mbs_clearance.generate.c_loader import load_c_model
from mbs_clearance.generate.cjacobians import translate
from mbs_clearance.laws.forces import contact_force_partials
from mbs_clearance.laws.lubrication.partials import N_INPUTS, N_OUTPUTS, film_partials
from mbs_clearance.laws.registry import CONTACT
from mbs_clearance.model import cases

sys.path.insert(0, str(Path(__file__).parent))
from test_generated_jacobians import check_against_differences  # noqa: E402

_DIFFERENCE_CASES = {
    "paper_slider_crank": cases.paper_slider_crank(),
    "paper_slider_crank+coulomb": cases.paper_slider_crank(
        friction_law="coulomb", friction_coefficient=0.3, friction_v0=0.5, friction_v1=1.0),
    "four_bar": cases.four_bar(clearance=1e-4),
    "paper_slider_crank_lubricated+long": cases.paper_slider_crank_lubricated(
        lubrication="long", film_fade_start=0.3, film_fade_end=0.7),
}


@pytest.mark.parametrize("case", sorted(_DIFFERENCE_CASES))
@pytest.mark.parametrize("mode", ["free", "contact"])
def test_c_jacobian_matches_central_differences_of_c_outputs(case, mode):
    """The C Jacobian of every output along every column of z equals central differences
    of the C plain model's outputs (test_generated_jacobians' check)."""
    linkage = _DIFFERENCE_CASES[case]
    check_against_differences(linkage, load_c_model(linkage), mode)


# ---------------------------------------------------------------------------- the film

_FILM_C = """
#include "mbs_core.h"
#include "runtime.h"
#include "jac_runtime.h"

/* the film's values and partials along each input (partials.film_partials' layout) */
void film_partials_c(const double *x, int64_t model, double *out) {
    jac_film_ends ends;
    double w, dw, v[5], d[5], e[12];
    for (int k = 0; k < 5 * 13; k++) out[k] = 0.0;
    if (!jac_film_values(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], model,
                         x[10], x[11], &ends, &w, &dw, v))
        return;
    for (int r = 0; r < 5; r++) out[r * 13 + 12] = v[r];
    for (int k = 0; k < 12; k++) {
        for (int m = 0; m < 12; m++) e[m] = m == k ? 1.0 : 0.0;
        jac_film_direction(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], model,
                           x[10], x[11], ends, w, dw, v[0], v[1], v[2], e[0], e[1], e[2],
                           e[3], e[4], e[5], e[6], e[7], e[8], e[9], e[10], e[11], d);
        for (int r = 0; r < 5; r++) out[r * 13 + k] = d[r];
    }
}

/* the contact law's force and partials at x = (delta, deltadot, deltadot_minus, K, e) */
void contact_partials_c(const double *x, int64_t model, double *d) {
    mbs_contact_force_partials(x[0], x[1], x[2], x[3], x[4], model, d);
}
"""


@pytest.fixture(scope="module")
def film_c():
    """The C film's partials through a small library of the core's headers (and, as
    `.contact`, the contact law's)."""
    core = Path(build.__file__).parent
    sources = [("film.c", _FILM_C)] + [(h, (core / h).read_text()) for h in
                                       ("runtime.h", "laws_generated.h", "jac_runtime.h")]
    ffi, lib = build.load("jac-elements-test", sources,
                          cdef="void film_partials_c(const double *x, int64_t model, "
                               "double *out); void contact_partials_c(const double *x, "
                               "int64_t model, double *d);")

    def partials(x, model):
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty((N_OUTPUTS, N_INPUTS + 1))
        lib.film_partials_c(ffi.from_buffer("double[]", x), model,
                            ffi.from_buffer("double[]", out))
        return out

    def contact(x, model):
        x = np.ascontiguousarray(x, dtype=float)
        d = np.full(6, np.nan)
        lib.contact_partials_c(ffi.from_buffer("double[]", x), model,
                               ffi.from_buffer("double[]", d))
        return d
    partials.contact = contact
    return partials


def _film_inputs(eps, angle, fade=(0.3, 0.9)):
    """(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, fade start, end): the journal at eps
    clearances towards `angle`, moving and squeezing, the bodies turning."""
    c = 1e-4
    return np.array([eps * c * np.cos(angle), eps * c * np.sin(angle), 0.03, -0.02, 150.0,
                     -20.0, 0.01, c, 0.02, 0.04, *fade])


@pytest.mark.parametrize("model", [0, 1], ids=["short", "long"])
@pytest.mark.parametrize("eps", [0.2, 0.6, 1e-10])
def test_c_film_partials_match_differences_and_python(film_c, model, eps):
    """The C film's partials along each of its inputs (inside the fade at eps 0.6, before it
    at 0.2; at 1e-10 clearances the centre's fallback) equal central differences of its own
    values (Richardson, away from the centre, where the frame's derivatives are smooth), and
    the Python partials (`film_partials`, complex steps) to 1e-12 of each row's largest
    entry (1e-7 at the centre)."""
    x = _film_inputs(eps, 0.7)
    got = film_c(x, model)
    ref = film_partials(*x, model)
    assert np.all(got[:, -1] != 0.0)
    scale = np.max(np.abs(ref[:, :-1]), axis=1, keepdims=True)
    # (at the centre's fallback the frame's derivatives cancel to about 1e-16 / 1e-8 of
    # their size: the two implementations round them differently to that level)
    rtol = 1e-12 if eps > 1e-3 else 1e-7
    assert np.all(np.abs(got - ref) <= rtol * np.maximum(scale, np.abs(ref[:, -1:])))
    if eps < 1e-3:
        return
    for k in range(N_INPUTS):
        h = 1e-5 * max(abs(x[k]), x[7] if k < 2 else 1e-3)

        def at(step, k=k):
            xx = x.copy()
            xx[k] += step
            return film_c(xx, model)[:, -1]
        d1 = (at(h) - at(-h)) / (2 * h)
        d2 = (at(h / 2) - at(-h / 2)) / h
        fd = (4 * d2 - d1) / 3
        err = np.abs(got[:, k] - fd)
        assert np.all(err <= 1e-6 * np.abs(got[:, :-1]).max(axis=1) + 1e-300), (k, got[:, k],
                                                                                  fd)


def test_c_film_without_partials_gives_nan_derivatives(film_c):
    """A film law without partials (id 2): values, and NaN derivatives."""
    x = _film_inputs(0.5, 1.1)
    got = film_c(x, 2)
    assert np.all(np.isfinite(got[:, -1])) and np.all(got[:, -1] != 0.0)
    assert np.all(np.isnan(got[:, :-1]))


# ------------------------------------------------------------------- the translator

def test_translate_blocks_calls_and_locals():
    """Blocks by indentation, integer loop variables and indices, a call with tuple results
    (pointers after the arguments) and tuple arguments (compound literals), locals collected
    for one declaration; a line with no C form refused."""
    lines = ["a = 1.0;", "for d in range(nd):", "    yo = 4 * (d + 1)",
             "    out[d] = a * y[yo + 0]", "if use[3] > use[2]:",
             "    for e in range(int(use[2]), int(use[3])):", "        d = int(use[9 + e])",
             "        b += dz[d * 8 + 2]", "x, z = f(jac, 3, (4, 5,), (p[1], p[2],))",
             "l_0_0 = math.sqrt(m_0_0)"]
    code, names = translate(lines)
    assert code == ["a = 1.0;",
                    "for (int64_t d = 0; d < nd; d++) {",
                    "    const int64_t yo = 4 * (d + 1);",
                    "    out[d] = a * y[yo + 0];",
                    "}",
                    "if (use[3] > use[2]) {",
                    "    for (int64_t e = (int64_t)(use[2]); e < (int64_t)(use[3]); e++) {",
                    "        const int64_t d = (int64_t)(use[9 + e]);",
                    "        b += dz[d * 8 + 2];",
                    "    }",
                    "}",
                    "f(jac, 3, (const int64_t[]){4, 5}, (const double[]){p[1], p[2]}, &x, &z);",
                    "l_0_0 = sqrt(m_0_0);"]
    assert names == ["a", "b", "x", "z", "l_0_0"]
    with pytest.raises(ValueError, match="no C form"):
        translate(["while x:"])


@pytest.mark.parametrize("model", range(len(CONTACT)))
def test_c_contact_partials_equal_python(film_c, model):
    """The contact law's force and partials in C (laws_generated.h, printed by the codegen)
    equal `forces.contact_force_partials` (the formula evaluated in Python) in compression,
    restitution, free flight and where the damping clamps the force at zero; every partial
    is also checked against differences in test_laws."""
    rng = np.random.default_rng(3)
    for x in [(2e-6, 0.2, 0.3, 4.8e11, 0.7), (2e-6, -0.2, 0.3, 4.8e11, 0.7),
              (-1e-6, 0.1, 0.3, 4.8e11, 0.7), (1e-6, -5.0, 0.1, 4.8e11, 0.3),
              *((rng.uniform(1e-8, 1e-4), rng.uniform(-2, 2), rng.uniform(0.01, 2),
                 rng.uniform(1e9, 1e12), rng.uniform(0.3, 1.0)) for _ in range(50))]:
        got = film_c.contact(x, model)
        # to round-off: Python evaluates a law's powers through pow, C as products
        np.testing.assert_allclose(got, contact_force_partials(*x, model), rtol=1e-14,
                                   atol=0.0, err_msg=str(x))
