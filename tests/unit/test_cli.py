"""The command line calls the public functions and reports bad input clearly."""

import json

import numpy as np
import pytest

from mbs_clearance import SliderCrank, load_trajectory, peak_base_force
from mbs_clearance.cli import main


def test_simulate_writes_trajectory_and_figure(tmp_path, capsys):
    out, fig = tmp_path / "t.npz", tmp_path / "f.png"
    assert main(["simulate", "--revolutions", "2", "--journal-radius", "0.0099",
                 "--out", str(out), "--plot", str(fig)]) == 0
    traj = load_trajectory(out)
    assert traj.mechanism == SliderCrank(journal_radius=0.0099)
    assert fig.stat().st_size > 10_000
    printed = capsys.readouterr().out.splitlines()
    peak2 = float(printed[2].split()[1])
    assert peak2 == pytest.approx(peak_base_force(traj.mechanism, 2), abs=0.01)
    np.testing.assert_allclose(traj.max_base_force(2), peak2, atol=0.01)


def test_simulate_with_another_integrator(capsys):
    assert main(["simulate", "--revolutions", "1", "--integrator", "dop853", "--rtol",
                 "1e-9"]) == 0
    peak1 = float(capsys.readouterr().out.splitlines()[1].split()[1])
    # the same peak as the default integrator, to the accuracy of both at rtol 1e-9
    assert peak1 == pytest.approx(peak_base_force(SliderCrank(), 1, rtol=1e-9), rel=1e-6)


def test_config_file_and_override(tmp_path, capsys):
    cfg = tmp_path / "m.json"
    cfg.write_text(json.dumps({"restitution": 0.5, "crank_length": 0.04}))
    assert main(["simulate", "--revolutions", "1", "--config", str(cfg),
                 "--crank-length", "0.045", "--out", str(tmp_path / "t.csv")]) == 0
    m = load_trajectory(tmp_path / "t.csv").mechanism
    assert (m.restitution, m.crank_length) == (0.5, 0.045)


@pytest.mark.parametrize("argv,message", [
    (["simulate", "--restitution", "0"], "restitution must be in the interval (0, 1]"),
    (["simulate", "--journal-radius", "0.02"], "journal_radius must be smaller"),
    (["simulate", "--config", "/nonexistent.json"], "cannot read mechanism file"),
    (["simulate", "--out", "x.txt", "--revolutions", "1"], "--out must end in .npz or .csv"),
    (["sensitivity", "--method", "fd", "--backend", "exudyn", "--integrator", "dop853"],
     "integrator applies to the reduced backend only"),
])
def test_bad_input_exits_with_message(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
