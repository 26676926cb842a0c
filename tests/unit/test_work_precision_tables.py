"""The work-precision command's target table: a ratio to our run where ours reaches the
target, a plain word where it does not (no "nan x")."""

from validation.work_precision import TARGETS, target_table

CASE = "c = 0.1 mm"


def _row(backend, method, setting, time, error):
    return dict(case=CASE, backend=backend, method=method, setting=setting, time=time,
                peak_error=error, series_error=error)


def test_a_target_ours_does_not_reach_says_so_and_gives_the_others_times():
    rows = [_row("reduced (ours)", "dopri5", "rtol 1e-07", 2.6e-3, 5e-3),     # only 1e-2
            _row("scipy", "DOP853", "rtol 1e-09", 0.157, 5e-4)]              # 1e-2, 1e-3
    lines = target_table(rows, CASE).splitlines()
    assert len(lines) == 2 + len(TARGETS)
    head = [c.strip() for c in lines[0].split("|")[1:-1]]
    cells = {t: dict(zip(head, (c.strip() for c in ln.split("|")[1:-1])))
             for t, ln in zip(TARGETS, lines[2:])}
    assert cells[1e-2]["ours (dopri5)"] == "2.6 ms (rtol 1e-07)"
    assert cells[1e-2]["scipy DOP853"] == "60.4 x"                 # 0.157 / 2.6e-3
    assert cells[1e-3]["ours (dopri5)"] == "not reached"
    assert cells[1e-3]["scipy DOP853"] == "157.0 ms"
    assert cells[1e-5]["scipy DOP853"] == "-"                      # nobody reaches 1e-5
    assert "nan" not in "\n".join(lines)
