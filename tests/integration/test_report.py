"""`mbs-clearance report --quick`: complete, consistent with the Python API, redrawable."""

import json
import re
import shutil

import numpy as np
import pytest

from mbs_clearance import SliderCrank, peak_base_force, simulate
from mbs_clearance.cli import main
from mbs_clearance.sensitivity import sensitivities
from validation.report import SECTIONS

pytestmark = pytest.mark.exudyn

FIGURES = ["fig3_response.png", "fig4_kinematic.png", "fig5_contact.png", "fig6_journal.png",
           "fig7a_fitness_fixed.png", "fig7b_force_fixed.png", "fig7a_fitness_uniform.png",
           "fig7b_force_uniform.png", "work_precision.png", "work_precision_series.png"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", "--quick", "--out", str(out)]) == 0
    return out


def test_files_sections_and_figures(report):
    out = report
    html = (out / "report.html").read_text()
    numbers = json.loads((out / "report.json").read_text())
    assert list(numbers) == list(SECTIONS)
    for key in SECTIONS:
        assert f'id="{key}"' in html
    for f in FIGURES:
        assert (out / "figures" / f).stat().st_size > 20_000, f  # not an empty canvas
        assert f'alt="{f}"' in html
    assert len(re.findall(r'src="data:image/png;base64,', html)) == len(FIGURES)
    assert "nan" not in json.dumps(numbers).lower()
    # run time is recorded (the 2-minute budget is a benchmark figure, not a test)
    assert set(numbers["environment"]["section_seconds"]) == set(SECTIONS)


def test_json_numbers_agree_with_the_python_api(report):
    out = report
    n = json.loads((out / "report.json").read_text())
    mech = SliderCrank()
    assert n["response"]["reduced"]["peak_base_force"][3] == pytest.approx(
        peak_base_force(mech, 4), rel=1e-12)
    assert n["response"]["ideal"]["peak_base_force"][3] == pytest.approx(
        simulate(mech, 4, backend="ideal").max_base_force(4), rel=1e-12)
    T = mech.period
    sens = sensitivities(mech, revolutions=4, t_eval=np.linspace(3 * T, 4 * T, 1441),
                         rtol=1e-9)
    for row, ref in zip(n["sensitivity"]["summary"], sens.summary()):
        assert row["parameter"] == ref["parameter"]
        assert row["mean_abs_normalized"] == pytest.approx(ref["mean_abs_normalized"],
                                                           rel=1e-9)
    opt = n["optimization"]
    best = mech.replace(crank_length=opt["results"]["fixed"]["crank_length"],
                        coupler_length=opt["results"]["fixed"]["coupler_length"])
    assert opt["results"]["fixed"]["best_peak_force"] == pytest.approx(
        peak_base_force(best, 4), rel=1e-9)
    paper = mech.replace(crank_length=0.040733, coupler_length=0.137468)
    assert opt["paper_optimum_in_our_models"]["fixed"]["reduced"] == pytest.approx(
        peak_base_force(paper, 4), rel=1e-12)
    table = {r["quantity"]: r for r in n["paper"]["rows"]}
    row = table["max |F12|, 4th revolution, original design (N)"]
    assert row["difference_percent"] == pytest.approx(100 * (row["ours"] / 8311 - 1))


def test_replot_redraws_without_recomputing(report, monkeypatch):
    import validation.report as rep

    out = report
    before = (out / "report.json").read_text()
    (out / "figures" / "fig3_response.png").unlink()

    def forbidden(*args, **kwargs):
        raise AssertionError("--replot must not recompute a section")

    for key in SECTIONS:
        monkeypatch.setattr(rep, f"section_{key}", forbidden)
    monkeypatch.setattr(rep, "simulate", forbidden)
    assert main(["report", "--replot", "--out", str(out)]) == 0
    assert (out / "figures" / "fig3_response.png").exists()
    assert (out / "report.json").read_text() == before


def test_replot_without_a_report_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["report", "--replot", "--out", str(tmp_path)])
    assert "needs a previous report" in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("chromium") is None,
                    reason="Debian's chromium is not installed (apt-get install chromium)")
def test_rendered_report_pages_are_not_blank(report, tmp_path):
    """Render the HTML in headless Chromium (validation/render_report.py): every page has
    content, and the whole report spans several pages of figures and tables."""
    from PIL import Image

    from validation.render_report import render

    out = report
    pages = render(out / "report.html", tmp_path)
    assert len(pages) >= 5
    for page in pages:
        pixels = np.asarray(Image.open(page).convert("L"), dtype=float)
        assert pixels.std() > 5, page  # not a uniform (empty) page
