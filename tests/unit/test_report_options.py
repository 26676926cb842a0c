"""`mbs-clearance report`: options that do not go together are refused with one line
before any computation (fast: nothing runs)."""

import pytest

from mbs_clearance.cli import main


@pytest.mark.parametrize("args, message", [
    (["--replot"], "needs a previous report"),
    (["--replot", "--full-data"], "--full-data cannot be combined with --replot"),
    (["--case", "slider_crank_two_clearances", "--replot"],
     "--replot, --map and --full-data belong to the paper's report"),
    (["--case", "slider_crank_two_clearances", "--full-data"],
     "--replot, --map and --full-data belong to the paper's report"),
    (["--set", "clearance=1e-4"], "--set applies with --case or --description"),
])
def test_refused_in_one_line_before_any_computation(args, message, tmp_path, capsys,
                                                    monkeypatch):
    import validation.report as rep

    def forbidden(*a, **k):
        raise AssertionError("a refused report must not compute")

    monkeypatch.setattr(rep, "run_sections", forbidden)
    out = tmp_path / "r"
    with pytest.raises(SystemExit) as exc:
        main(["report", *args, "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()
