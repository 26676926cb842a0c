"""The report of any linkage (`mbs-clearance report --case NAME`), quick, on the
two-clearance slider-crank: its numbers against the library's own calls."""

import json

import numpy as np
import pytest

from mbs_clearance.cli import main
from mbs_clearance.model import cases

# slow: the quick report runs every study of the linkage (about 2 minutes on a CI machine)
pytestmark = [pytest.mark.exudyn, pytest.mark.slow]

CASE = "slider_crank_two_clearances"


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("linkage_report") / "report"
    assert main(["report", "--case", CASE, "--quick", "--out", str(out)]) == 0
    return out


def test_every_section_with_its_figure(report):
    from markupsafe import escape

    from validation.linkage_report import TITLES

    html = (report / "report.html").read_text()
    for title in TITLES.values():
        assert str(escape(title)) in html
    for fig in ("response", "agreement", "sensitivity", "tolerance", "regimes"):
        assert (report / "figures" / f"{fig}.png").stat().st_size > 5000
    assert html.count("data:image/png;base64,") == 5


def test_numbers_are_the_library_s(report):
    """The response's peaks are `simulate`'s (to its own accuracy request); the study
    sizes follow their closed forms: Sobol N (d + 2) runs without second order, the regime
    map's points the product of its axes'."""
    from mbs_clearance import simulate
    from mbs_clearance.solve.accuracy import revolution_peaks

    n = json.loads((report / "report.json").read_text())
    lk = cases.CASES[CASE]()
    peaks = revolution_peaks(simulate(lk, 2))
    np.testing.assert_allclose(n["response"]["peaks"], peaks, rtol=1e-12)
    assert n["response"]["accuracy_ok"] and n["response"]["error_estimate"] <= 1e-5
    tol = n["tolerance"]
    assert tol["runs"] == 8 * (len(tol["names"]) + 2)
    assert len(tol["names"]) == 2 * len(lk.clearance_joints)
    assert sum(n["regimes"]["counts"].values()) == n["regimes"]["points"] == 3 * 2
    # the gradient's peak is the same revolution's peak (finite differences at rtol 1e-11)
    assert n["sensitivity"]["peak"] == pytest.approx(peaks[-1], rel=1e-5)


def test_both_models_agree_within_their_error_bars(report):
    """The converged cross-check: Exudyn extrapolated from three steps against the reduced
    model at accuracy 1e-6; their difference within the two bars (a model difference would
    show there)."""
    rows = json.loads((report / "report.json").read_text())["agreement"]["rows"]
    assert rows
    for r in rows:
        assert abs(r["difference"]) <= r["bars"], r
        assert r["verdict"] == "agree"
