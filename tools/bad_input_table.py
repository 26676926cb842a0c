"""Run every bad-input case and write the table docs/bad_input.md.

    python tools/bad_input_table.py              # all cases; writes docs/bad_input.md
    python tools/bad_input_table.py --cli-only   # print the command-line table only

Command-line cases run in this process through `mbs_clearance.cli.main(argv)`, in a
temporary working folder holding a few files of a user (``user.txt`` ...), capturing stderr
and the exit status. Library cases run through the Python API in a worker process (so a case
that runs away is stopped after `LIBRARY_TIMEOUT` seconds and reported as such), capturing
the exception type and the first line of its message, or the value returned and any warning.
The table records what happens, whatever it is: regenerate it after changing any check.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import queue
import re
import shlex
import subprocess
import sys
import tempfile
import threading
import traceback
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "bad_input.md"
LIBRARY_TIMEOUT = 120.0

# --------------------------------------------------------------------------- CLI cases
#: (command line after "mbs-clearance", what it shows) - all run in the temporary folder
CLI_CASES: list[tuple[str, str]] = [
    # options and values
    ("", "no subcommand"),
    ("nope", "unknown subcommand"),
    ("simulate --revolutions 0", "count below its minimum"),
    ("simulate --revolutions -1", "negative count"),
    ("simulate --revolutions 2.5", "count not an integer"),
    ("simulate --duration 0.1", "a duration for a driven linkage"),
    ("simulate --window -1", "a negative time window"),
    ("simulate --rtol 0", "tolerance zero"),
    ("simulate --rtol nan", "tolerance NaN"),
    ("simulate --rtol -1e-8", "tolerance negative"),
    ("simulate --backend exudyn --step-size 0", "step size zero"),
    ("simulate --backend nope", "unknown backend"),
    ("simulate --integrator nope", "unknown integrator"),
    ("simulate --crank-length abc", "field not a number"),
    ("simulate --crank-length nan", "field NaN"),
    ("simulate --crank-speed 5000rpms", "field with an unknown unit"),
    ("simulate --set crank_speed=5mm", "a value with a unit of another quantity"),
    ("map --sweep clearance=1rpm:2rpm:3", "a sweep with a unit of another quantity"),
    ("simulate --crank-length -0.05", "field negative"),
    ("simulate --restitution 0", "field out of range"),
    ("simulate --journal-radius 0.02", "journal larger than the bearing"),
    ("simulate --crank-inertia abc", "optional field neither a number nor none"),
    ("simulate --contact-model nope", "unknown contact law"),
    ("simulate --config /nonexistent.json", "missing config file"),
    ("simulate --config user.txt", "config file not JSON"),
    ("simulate --config list.json", "config file not a JSON object"),
    ("simulate --config unknown_field.json", "config file with an unknown field"),
    ("simulate --case nope", "unknown named case"),
    ("simulate --case four_bar --description user.json", "a case and a description together"),
    ("simulate --set clerance=1e-4", "an unknown field of the paper's case"),
    ("simulate --case four_bar --set clearance", "an override without a value"),
    ("simulate --case four_bar --set clerance=1e-4", "unknown override of a case"),
    ("simulate --case four_bar --set clearance=-1", "override out of range"),
    ("simulate --case four_bar --set crank_length=2.8", "four-bar no longer a crank-rocker"),
    ("simulate --case four_bar --journal-radius 0.05", "a field the case does not have"),
    ("simulate --case four_bar --plot f.png", "figure of a case"),
    ("simulate --settled 3", "--settled without a case"),
    ("simulate --case four_bar --settled 0", "--settled zero"),
    ("simulate --case four_bar --settled 2 --backend ideal", "--settled with the ideal backend"),
    ("simulate --description /nonexistent.json", "missing description file"),
    ("simulate --description user.txt", "description file neither JSON nor TOML"),
    ("simulate --description list.json", "description file not a linkage"),
    ("simulate --description user.json", "description file lacking its items"),
    ("sensitivity --parameters ''", "empty parameter list"),
    ("sensitivity --parameters 'crank_length,,slider_mass'", "empty name in the list"),
    ("sensitivity --parameters nope", "unknown parameter"),
    ("sensitivity --revolutions 0", "count below its minimum"),
    ("sensitivity --method fd --backend exudyn --integrator dop853",
     "option of another backend"),
    ("optimize --population 3", "population below its minimum"),
    ("optimize --generations 0", "count below its minimum"),
    ("optimize --saturation -1", "negative count"),
    ("optimize --workers 0", "count below its minimum"),
    ("optimize --revolution 0", "count below its minimum"),
    ("optimize --seed -1", "negative seed"),
    ("optimize --crank-bounds nan 0.06", "bound NaN"),
    ("optimize --crank-bounds 0.06 0.04", "bounds reversed"),
    ("compare --h-max -1", "largest step negative"),
    ("compare --h-max 0", "largest step zero"),
    ("compare --revolutions 0", "count below its minimum"),
    ("compare --step-size 0", "step size zero"),
    ("compare --backend-a nope", "unknown backend"),
    ("compare --contact nope --no-plot", "unknown Exudyn contact variant"),
    ("compare --backend-b ideal --h-max 1e-300 --revolutions 1 --no-plot",
     "a run that fails (step too small to advance)"),
    ("stress --backend nope", "unknown backend"),
    ("bench --repeats 0", "count below its minimum"),
    ("bench --repeats -3", "negative count"),
    # sizes: bounded by an estimate of the work before any
    ("simulate --revolutions 1000000000", "a count of revolutions beyond any run's steps"),
    ("simulate --case four_bar --revolutions 1 --settled 1000000000",
     "a settling run beyond any run's steps"),
    ("simulate --case flores_translational_slider_crank --duration 1e9",
     "a free linkage's duration beyond any run's steps"),
    ("simulate --backend exudyn --step-size 1e9", "a step longer than a revolution"),
    ("simulate --backend exudyn --step-size 1e-12", "a step too small for the revolutions"),
    ("lyapunov --case flores_translational_slider_crank --duration 1e9",
     "a duration beyond any run's steps"),
    ("animate --frames 10000000", "frames beyond the memory"),
    ("bench --quick --no-exudyn --repeats 1000000000", "repeats beyond a command's work"),
    ("map --sweep clearance=1e-5:1e-4:1000 --workers 1000000000",
     "workers beyond the memory of their threads"),
    ("compare --step-size 1e9", "a step longer than a revolution"),
    ("report --replot --out empty", "--replot without a report"),
    ("report --replot --out mixed_report", "--replot on a folder mixing two runs"),
    # output paths (checked before any computation)
    ("simulate --out t.txt", "trajectory file with a wrong suffix"),
    ("simulate --out dir.npz", "a folder where a file is expected"),
    ("simulate --out user.txt/t.npz", "a path under a regular file"),
    ("simulate --out /proc/t.npz", "a folder that is not writable"),
    ("simulate --out user.npz", "a file that mbs-clearance did not write"),
    ("simulate --plot f.txt", "figure file with an unknown format"),
    ("simulate --plot dir.png", "a folder where a file is expected"),
    ("simulate --plot user.txt/f.png", "a path under a regular file"),
    ("simulate --plot /proc/f.png", "a folder that is not writable"),
    ("simulate --plot user.png", "a file that mbs-clearance did not write"),
    ("sensitivity --out user.txt", "a file where a folder is expected"),
    ("sensitivity --out notes", "a folder holding a user's files"),
    ("sensitivity --out /proc/sens", "a folder that is not writable"),
    ("optimize --out user.txt", "a file where a folder is expected"),
    ("optimize --out notes", "a folder holding a user's files"),
    ("optimize --out user.txt/opt", "a path under a regular file"),
    ("optimize --out /proc/opt", "a folder that is not writable"),
    ("compare --out dir.png", "a folder where a file is expected"),
    ("compare --out /proc/c.png", "a folder that is not writable"),
    ("compare --out user.png", "a file that mbs-clearance did not write"),
    ("stress --json /proc/s.json", "a folder that is not writable"),
    ("stress --json dir.json", "a folder where a file is expected"),
    ("stress --json user.json", "a file that mbs-clearance did not write"),
    ("bench --out user.txt", "a file where a folder is expected"),
    ("bench --out /proc/bench", "a folder that is not writable"),
    ("report --out user.txt", "a file where a folder is expected"),
    ("report --out notes", "a folder holding a user's files"),
    ("report --out /proc/report", "a folder that is not writable"),
    # ---- sizes refused before the work, unreachable schedulers, map and report inputs,
    # ---- tolerance ranges (files from `_make_size_files`)
    ("map --sweep clearance=1e-5:1e-3:log:10000 --sweep crank_speed=100:1000:10000",
     "a map of 10^8 points"),
    ("map --sweep clearance=1e-5:1e-3:1000 --sweep crank_speed=100:1000:1000",
     "a map of 10^6 points"),
    ("map --sweep clearance=1e-5:1e-3:1000000000", "one sweep axis of 10^9 points"),
    ("map --sweep clearance=1e-5:1e-3:3 --revolutions 1000000000",
     "10^9 revolutions per map point"),
    ("sensitivity --revolutions 1000000000", "10^9 revolutions of sensitivities"),
    ("lyapunov --revolutions 1000000000", "10^9 revolutions of a Lyapunov exponent"),
    ("optimize --population 1000000000", "a GA population of 10^9"),
    ("optimize --population 10000 --generations 100000", "10^9 GA evaluations"),
    ("tolerance tol_ok.json --sobol 1073741824", "a Sobol sample of 2^30"),
    ("tolerance tol_ok.json --sobol 0 --monte-carlo 1000000000", "a Monte Carlo of 10^9"),
    ("tolerance tol_negative.json", "a uniform range leaving the field's range"),
    ("tolerance tol_normal.json", "a normal whose 5 sigma leave the field's range"),
    ("tolerance tol_fit.json --sobol 0 --monte-carlo 4 --wear 1",
     "a wear of 1 m on a 10 mm bearing"),
    ("map --sweep clearance=1e-5:1e-3:3 --out notes", "map into a folder of a user's files"),
    ("map --sweep clearance=1e-5:1e-3:3 --out bad_map",
     "map into a folder whose map.nc is not a map"),
    ("report --map bad.nc", "a damaged regime map"),
    ("report --map user.json", "a file that is not a regime map"),
    ("report --map missing.nc", "a regime map that does not exist"),
    ("report --map bad.nc --replot", "--map with --replot"),
    ("wear --cycles 1e13", "a wear life of 10^13 cycles"),
    ("wear --case four_bar", "a wear life of a joint without a wear coefficient"),
    ("wear --joint crank_pivot", "a wear life of a joint that is not a clearance joint"),
    ("wear --tolerance 0", "a zero tolerance of the wear life's intervals"),
    ("wear --out life.csv", "a wear life written to a file type it is not"),
]


# ---- descriptions and input files: hostile names, missing keys, sizes, loops that cannot
# close (the files are written by `_make_description_files`, only for the case naming them)
CLI_CASES += [
    ("simulate --description evil_name.json",
     "a linkage name holding Python that would run on import"),
    ("simulate --description evil_joint.json",
     "a clearance joint name holding Python that would run on import"),
    ("simulate --description no_mass.json", "a body lacking its mass"),
    ("simulate --description unknown_key.json", "a clearance joint with an unknown key"),
    ("simulate --description same_pin.json", "a second clearance joint on the same pin"),
    ("simulate --description short_coupler.json", "a four-bar that cannot close"),
    ("simulate --description many_points.json", "a body with 1.5 million points"),
    ("simulate --description points_200.json", "a body with 200 points"),
    ("simulate --description /dev/zero", "an endless description file"),
    ("simulate --config /dev/zero", "an endless config file"),
]

#: a name that, pasted into generated source, would write the file PWNED when imported
EVIL_NAME = 'x"""\nimport pathlib; pathlib.Path("PWNED").write_text("ran")\n"""'


def _make_description_files(folder: Path, command: str) -> None:
    """The description files of the cases above that `command` names."""
    from mbs_clearance.model.cases import four_bar, paper_slider_crank

    def paper():
        return paper_slider_crank().to_dict()

    def evil_name():
        d = paper()
        d["name"] = EVIL_NAME
        return d

    def evil_joint():
        d = paper()
        d["clearance_joints"][0]["name"] = EVIL_NAME
        return d

    def no_mass():
        d = paper()
        del d["bodies"][1]["mass"]
        return d

    def unknown_key():
        d = paper()
        d["clearance_joints"][0]["radius"] = 0.01
        return d

    def same_pin():
        d = paper()
        d["clearance_joints"].append({**d["clearance_joints"][0], "name": "second"})
        return d

    def short_coupler():
        d = four_bar().to_dict()
        d["bodies"][1]["points"] = {"crank_end": [-0.1, 0.0], "rocker_end": [0.1, 0.0]}
        return d

    def points(n):
        d = paper()
        d["bodies"][2]["points"].update({f"p{i}": [0.0, 0.0] for i in range(n)})
        return d

    makers = {"evil_name": evil_name, "evil_joint": evil_joint, "no_mass": no_mass,
              "unknown_key": unknown_key, "same_pin": same_pin,
              "short_coupler": short_coupler, "many_points": lambda: points(1_500_000),
              "points_200": lambda: points(200)}
    for name, make in makers.items():
        if f"{name}.json" in command:
            (folder / f"{name}.json").write_text(json.dumps(make()))


def _make_user_files(folder: Path) -> None:
    """The files a user has in the working folder of the CLI cases."""
    (folder / "user.txt").write_text("my notes\n")
    (folder / "user.npz").write_bytes(b"not a trajectory")
    (folder / "user.png").write_bytes(b"\x89PNG\r\n\x1a\n my own picture")
    (folder / "user.json").write_text('{"mine": true}\n')
    (folder / "list.json").write_text("[1, 2]\n")
    (folder / "unknown_field.json").write_text('{"crank_lenght": 0.05}\n')
    for name in ("dir.npz", "dir.png", "dir.json", "empty"):
        (folder / name).mkdir()
    (folder / "notes").mkdir()
    (folder / "notes" / "todo.txt").write_text("mine\n")
    # a report folder whose data/ comes from one run and report.json from another: what
    # a killed run followed by a copy of old files produces
    from mbs_clearance._io import OutputDir

    for run in ("a", "b"):
        with OutputDir(folder / f"report_{run}", "report",
                       run_id=f"20260101T000000Z-1-{run * 6}") as staged:
            (staged.path / "data").mkdir()
            (staged.path / "data" / "response_reduced.npz").write_bytes(run.encode())
            (staged.path / "report.json").write_text(
                json.dumps({"environment": {"run_id": staged.run_id}}))
            staged.commit()
    mixed = folder / "mixed_report"
    os.rename(folder / "report_a", mixed)
    os.replace(folder / "report_b" / "data" / "response_reduced.npz",
               mixed / "data" / "response_reduced.npz")
    _make_size_files(folder)


# ---- files of the cases on sizes, tolerance ranges and regime maps
def _make_size_files(folder: Path) -> None:
    """Tolerance inputs inside and outside the fields' ranges, a damaged regime map and a
    map folder holding one."""
    (folder / "tol_ok.json").write_text('{"crank_length": {"band": [0.05, 1e-4]}}\n')
    (folder / "tol_negative.json").write_text('{"crank_length": {"uniform": [-1, 0.05]}}\n')
    (folder / "tol_normal.json").write_text('{"slider_mass": {"normal": [0.14, 0.05]}}\n')
    (folder / "tol_fit.json").write_text(
        '{"radial_clearance": {"fit": "H7/g6", "diameter": 0.02}}\n')
    (folder / "bad.nc").write_bytes(b"CDF\x01 cut short")
    (folder / "bad_map").mkdir()
    (folder / "bad_map" / "map.nc").write_bytes(b"not a map")


def run_cli_case(command: str) -> dict:
    """Run ``mbs-clearance COMMAND`` in this process: exit status and stderr."""
    from mbs_clearance.cli import main

    err, out = io.StringIO(), io.StringIO()
    status: object
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            status = main(shlex.split(command))
        except SystemExit as exc:
            status = exc.code
        except BaseException:  # noqa: BLE001 - recorded: a traceback is what the user sees
            traceback.print_exc()
            status = "uncaught exception"
    status = 0 if status is None else status
    return {"command": command, "status": status, "stderr": err.getvalue()}


def run_cli_cases() -> list[dict]:
    """All CLI cases, each in a fresh temporary working folder."""
    rows = []
    cwd = os.getcwd()
    for command, what in CLI_CASES:
        with tempfile.TemporaryDirectory() as tmp:
            _make_user_files(Path(tmp))
            _make_description_files(Path(tmp), command)
            os.chdir(tmp)
            try:
                row = run_cli_case(command)
            finally:
                os.chdir(cwd)
        row["what"] = what
        rows.append(row)
    return rows


def _shown(stderr: str) -> str:
    """What the user sees on stderr, for the table (a traceback as its last line)."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if any(ln.startswith("Traceback") for ln in lines):
        return f"traceback ({len(lines)} lines): {lines[-1]}"
    return " / ".join(lines)


# --------------------------------------------------------------------------- library cases
#: (Python expression, what is tried) - evaluated in the worker with the names of
#: `_library_namespace`
LIBRARY_CASES: list[tuple[str, str]] = [
    ("simulate(M, 1, t_eval=[np.nan])", "t_eval NaN"),
    ("simulate(M, 1, t_eval=[])", "t_eval empty"),
    ("simulate(M, 1, event_tol=0.0)", "event_tol zero"),
    ("simulate(M, 1, event_tol=-1e-12)", "event_tol negative"),
    ("simulate(M, 1, event_tol=np.nan)", "event_tol NaN"),
    ("simulate(M, 1, h0=np.nan)", "h0 NaN"),
    ("simulate(M, 1, h_max=0.0)", "h_max zero"),
    ("simulate(M, 1, h_max=-1e-4)", "h_max negative"),
    ("simulate(M, 1, n_samples=-1)", "n_samples negative"),
    ("peak_base_force(M, 1, rtol=np.float64(1e-8))", "numpy scalar rtol (valid)"),
    ("peak_base_force(M, np.int64(1))", "numpy integer revolution (valid)"),
    ("simulate(M, np.int64(1)).revolutions", "numpy integer revolutions (valid)"),
    ("sensitivities(M, revolutions=True)", "revolutions=True"),
    ("trajectory().max_base_force(True)", "revolution=True"),
    ("peak_base_force(M, True)", "revolution=True"),
    ("save_roundtrip(SliderCrank(crank_length=np.float32(0.05)), 'npz')",
     "numpy float32 field, then save"),
    ("save_roundtrip(SliderCrank(slider_mass=np.int64(1)), 'csv')",
     "numpy int64 field, then save"),
    ("save_roundtrip(SliderCrank(crank_length=Fraction(1, 20)), 'npz')",
     "Fraction field, then save"),
    ("simulate(SliderCrank(crank_speed=1e6), 1).stats['max_penetration_clearance']",
     "crank speed 1e6 rad/s: physically meaningless"),
    ("load_trajectory(crafted('peaks')).max_base_force(1)",
     "trajectory file with a crafted peaks entry"),
    ("load_trajectory(crafted('short'))", "trajectory file with arrays of mismatched length"),
    ("load_trajectory(crafted('missing'))", "trajectory file missing an array"),
    ("load_trajectory(crafted('meta'))", "trajectory file whose metadata is not an object"),
    ("load_trajectory(crafted('no_mechanism'))", "trajectory metadata without the mechanism"),
    ("load_trajectory(crafted('csv_header'))", "csv trajectory with a wrong header"),
    ("load_sensitivities(crafted('peaks'))", "a trajectory file read as sensitivities"),
    ("OptimizationResult.from_json(crafted('result_missing_key'))",
     "optimisation result missing a key"),
    ("SliderCrank.from_json(crafted('list_json'))", "mechanism file not a JSON object"),
    ("sensitivities(M, ['crank_length'], revolutions=2).chaotic",
     "chaos flag with fewer than 3 revolutions"),
    ("simulate(cases.four_bar(), 1, start=(1.0, 2.0))", "start that is not a Start"),
    ("simulate(cases.four_bar(), 1, start=Start(np.zeros(3), np.zeros(1), np.ones(1), 1, "
     "'four_bar'))", "start of the wrong size"),
    ("simulate(cases.four_bar(), 1, start=Start(np.zeros(4), np.zeros(1), np.ones(1), 1, "
     "'paper_slider_crank'))", "start of another linkage"),
    ("simulate(M, 1, start=None)", "start for a SliderCrank"),
    # ---- sizes refused before the work, tolerance ranges, flagged runs, adapting defaults
    # ---- (names from `_sizes_namespace`)
    ("regime_map(M, ['clearance=1e-5:1e-3:log:10000', 'crank_speed=100:1000:10000'])",
     "a map of 10^8 points"),
    ("regime_map(M, 'clearance=1e-5:1e-3:3', revolutions=10**9)",
     "10^9 revolutions per map point"),
    ("sensitivities(M, ['crank_length'], revolutions=10**9)", "10^9 revolutions"),
    ("lyapunov_exponent(M, revolutions=10**9)", "10^9 revolutions"),
    ("optimize_link_lengths(M, population=10**9, progress=False)", "population 10^9"),
    ("tolerance_study({'crank_length': band(0.05, 1e-4)}, sobol=2**30)",
     "Sobol sample of 2^30"),
    ("tolerance_study({'crank_length': Uniform(-1, 0.05)})",
     "uniform range leaving the field's range"),
    ("tolerance_study({'radial_clearance': FitClearance('H7/g6', 0.02)}, sobol=0, "
     "monte_carlo=4, wear=[1.0])", "wear of 1 m on a 10 mm bearing"),
    ("simulate(SliderCrank(youngs_modulus=1e15), 4).stats['accuracy_ok']",
     "E = 1e15 Pa: flagged, warns"),
    ("simulate(SliderCrank(crank_mass=1e-6, coupler_mass=1e-6, slider_mass=1e-6), 4)"
     ".stats['accuracy_ok']", "1e-6 kg masses: flagged, warns"),
    ("lyapunov_exponent(M, revolutions=40).transient", "default transient with 40 revolutions"),
    ("load_map(crafted_map())", "a damaged regime map"),
]


# ---- descriptions: names, keys, sizes, loops (names from `_description_namespace`)
LIBRARY_CASES += [
    ("Linkage.from_dict({**paper_dict(), 'name': EVIL_NAME})",
     "a linkage name holding Python that would run on import"),
    ("Body('crank arm', 1.0, 1.0)", "a body name that is not an identifier"),
    ("Linkage.from_dict(without_mass())", "a body lacking its mass"),
    ("Linkage.from_dict(renamed('coupler', 'gravity'))",
     "a body named after a key of the description"),
    ("Linkage.from_dict(renamed('crank_coupler', 'drive'))",
     "a joint named after a key of the description"),
    ("cases.paper_slider_crank().replace(clearance_joints=2 * "
     "cases.paper_slider_crank().clearance_joints)", "the same clearance joint twice"),
    ("Body('crank', 1.0, 1.0, {f'p{i}': (0.0, 0.0) for i in range(1_500_000)})",
     "a body with 1.5 million points"),
    ("cases.four_bar().with_parameter('coupler.crank_end.x', -0.1).with_parameter("
     "'coupler.rocker_end.x', 0.1).assemble()", "a four-bar that cannot close"),
    ("Linkage.from_file('/dev/zero')", "an endless description file"),
]


def _description_namespace() -> dict:
    """Names the description cases use."""
    from mbs_clearance.model import cases
    from mbs_clearance.model.linkage import Body, Linkage

    def paper_dict():
        return cases.paper_slider_crank().to_dict()

    def without_mass():
        d = paper_dict()
        del d["bodies"][0]["mass"]
        return d

    def renamed(name, new):
        import json

        text = json.dumps(cases.four_bar().to_dict())
        return json.loads(re.sub(f'"{name}(?=[".])', f'"{new}', text))

    return {"Linkage": Linkage, "Body": Body, "paper_dict": paper_dict,
            "without_mass": without_mass, "renamed": renamed, "EVIL_NAME": EVIL_NAME}


def _library_namespace(tmp: Path) -> dict:
    """Names the library cases use (imports, the paper's mechanism M, file makers)."""
    from fractions import Fraction

    import numpy as np

    from mbs_clearance import SliderCrank, load_trajectory, peak_base_force, simulate
    from mbs_clearance.analysis.sensitivity import load_sensitivities, sensitivities
    from mbs_clearance.model import cases
    from mbs_clearance.solve.linkage_model import Start
    from mbs_clearance.studies.optimize import OptimizationResult

    cache: dict = {}

    def trajectory():
        if "traj" not in cache:
            cache["traj"] = simulate(SliderCrank(), 1)
        return cache["traj"]

    def save_roundtrip(mech, suffix):
        path = tmp / f"roundtrip.{suffix}"
        simulate(mech, 1).save(path)
        return type(load_trajectory(path).mechanism.crank_length).__name__

    def crafted(kind):
        base = tmp / "base.npz"
        if not base.exists():
            trajectory().save(base)
        data = dict(np.load(base))
        meta = json.loads(str(data["meta"]))
        if kind == "peaks":
            meta["peaks"] = [1.0]
            data["meta"] = np.array(json.dumps(meta))
        elif kind == "short":
            data["base_force"] = data["base_force"][:-5]
        elif kind == "missing":
            del data["crank_moment"]
        elif kind == "meta":
            data["meta"] = np.array("[1, 2]")
        elif kind == "no_mechanism":
            del meta["mechanism"]
            data["meta"] = np.array(json.dumps(meta))
        elif kind == "csv_header":
            path = tmp / "bad.csv"
            trajectory().save(path)
            lines = path.read_text().splitlines()
            lines[1] = lines[1].replace("crank_moment", "crank_torque")
            path.write_text("\n".join(lines) + "\n")
            return path
        elif kind == "result_missing_key":
            path = tmp / "result.json"
            full = json.loads(json.dumps(_small_result().to_dict()))
            del full["history"]
            path.write_text(json.dumps(full))
            return path
        elif kind == "list_json":
            path = tmp / "list.json"
            path.write_text("[1, 2]")
            return path
        path = tmp / f"crafted_{kind}.npz"
        np.savez(path, **data)
        return path

    def _small_result():
        from mbs_clearance.studies.optimize import optimize_link_lengths

        return optimize_link_lengths(SliderCrank(), population=4, generations=1, seed=1,
                                     executor="serial", refine=False, progress=False)

    return {"np": np, "Fraction": Fraction, "SliderCrank": SliderCrank, "M": SliderCrank(),
            "simulate": simulate, "peak_base_force": peak_base_force,
            "sensitivities": sensitivities, "load_trajectory": load_trajectory,
            "load_sensitivities": load_sensitivities, "OptimizationResult": OptimizationResult,
            "trajectory": trajectory, "save_roundtrip": save_roundtrip, "crafted": crafted,
            "cases": cases, "Start": Start, **_description_namespace(),
            **_sizes_namespace(tmp)}


# ---- names of the library cases on sizes, tolerance ranges and regime maps
def _sizes_namespace(tmp: Path) -> dict:
    from mbs_clearance import lyapunov_exponent, optimize_link_lengths, regime_map
    from mbs_clearance.studies.sweep import load_map
    from mbs_clearance.studies.tolerance import FitClearance, Uniform, band, tolerance_study

    def crafted_map():
        path = tmp / "damaged_map.nc"
        path.write_bytes(b"CDF\x01 cut short")
        return path

    return {"regime_map": regime_map, "lyapunov_exponent": lyapunov_exponent,
            "optimize_link_lengths": optimize_link_lengths, "tolerance_study": tolerance_study,
            "Uniform": Uniform, "band": band, "FitClearance": FitClearance,
            "load_map": load_map, "crafted_map": crafted_map}


def _first_line(text: str) -> str:
    lines = str(text).strip().splitlines()
    return lines[0] if lines else ""


def run_library_case(expr: str, namespace: dict) -> dict:
    """Evaluate `expr`: the exception (type, first line) or the value, and the warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = eval(expr, namespace)  # noqa: S307 - our own fixed expressions
        except Exception as exc:  # noqa: BLE001 - recorded
            outcome = {"raises": type(exc).__name__, "message": _first_line(exc)}
        else:
            if hasattr(value, "t") and hasattr(value, "mechanism"):
                n = len(value.t)
                text = f"a {type(value).__name__} ({n} sample{'' if n == 1 else 's'})"
            else:
                import numpy as np

                # a numpy scalar as the number it holds (numpy 2 writes np.float64(...))
                text = repr(value.item() if isinstance(value, np.generic) else value)
            outcome = {"returns": text if len(text) <= 60 else text[:57] + "..."}
    outcome["warnings"] = sorted({f"{w.category.__name__}: {_first_line(w.message)}"
                                  for w in caught})
    return outcome


def _worker() -> None:
    """Read case indices on stdin, answer one JSON line each on stdout (fd kept private)."""
    channel = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)   # anything the library prints goes to stderr, not into the channel
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)   # files by relative names: messages free of the temporary path
        namespace = _library_namespace(Path("."))
        for line in sys.stdin:
            expr = LIBRARY_CASES[int(line)][0]
            channel.write(json.dumps(run_library_case(expr, namespace)) + "\n")
            channel.flush()


def run_library_cases(timeout: float = LIBRARY_TIMEOUT) -> list[dict]:
    """All library cases in a worker process; a case running longer than `timeout` seconds
    is stopped (the worker is killed and restarted for the next case)."""
    rows: list[dict] = []
    proc = None
    answers: queue.Queue = queue.Queue()

    def start():
        p = subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                             cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})

        def read(p=p, answers=answers):
            with p.stdout:          # closed at the worker's end (no unclosed pipe left)
                for ln in p.stdout:
                    answers.put(ln)
            answers.put(None)

        threading.Thread(target=read, daemon=True).start()
        return p

    try:
        for k, (expr, what) in enumerate(LIBRARY_CASES):
            if proc is None:
                answers = queue.Queue()
                proc = start()
            proc.stdin.write(f"{k}\n")
            proc.stdin.flush()
            try:
                line = answers.get(timeout=timeout)
            except queue.Empty:
                line = "timeout"
            if line is None or line == "timeout":
                proc.kill()
                proc.wait()
                proc.stdin.close()
                proc = None
                outcome = ({"raises": "(no answer)",
                            "message": f"still running after {timeout:g} s: stopped",
                            "warnings": []} if line == "timeout" else
                           {"raises": "(process died)", "message": "the worker process "
                            "ended (killed or crashed)", "warnings": []})
            else:
                outcome = json.loads(line)
            rows.append({"expr": expr, "what": what, **outcome})
    finally:
        if proc is not None:
            proc.stdin.close()
            proc.wait(timeout=30)
    return rows


# --------------------------------------------------------------------------- the document
def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _text(text: str) -> str:
    """A table cell outside a code span: brackets escaped, so `[a][b]` is not a link."""
    return _cell(text).replace("[", "\\[").replace("]", "\\]")


def cli_table(rows: list[dict]) -> str:
    lines = ["| input | case | what the user sees (stderr) | exit status |",
             "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| `{_cell(('mbs-clearance ' + r['command']).strip())}` | "
                     f"{_text(r['what'])} | "
                     f"{_text(_shown(r['stderr']))} | {r['status']} |")
    return "\n".join(lines)


def library_table(rows: list[dict]) -> str:
    lines = ["| input | case | exception or result | warnings |", "|---|---|---|---|"]
    for r in rows:
        result = (f"{r['raises']}: {r['message']}" if "raises" in r
                  else f"returns {r['returns']}")
        lines.append(f"| `{_cell(r['expr'])}` | {_text(r['what'])} | {_text(result)} | "
                     f"{_text('; '.join(r['warnings'])) or '-'} |")
    return "\n".join(lines)


CLI_HEADING = "## Command line"
LIBRARY_HEADING = "## Python API"


def document(cli_rows: list[dict], library_rows: list[dict]) -> str:
    return f"""# Bad input: what the user sees

Generated by `python tools/bad_input_table.py` (do not edit by hand): every case is run and
what happens is recorded. Command-line cases run `mbs-clearance ...` in a folder holding a
few files of a user (`user.txt`, `user.npz`, `user.png`, `user.json`, a folder `notes/` with
a file, empty folders `dir.npz/`, `dir.png/`, `dir.json/`, `empty/`, and `mixed_report/`, a
report folder whose data comes from two runs). Exit status 2: bad input (usage or value);
1: a failure while running. Set `MBS_CLEARANCE_DEBUG=1` to see the traceback of an error.
Output paths are checked before any computation; existing files are replaced only when an
earlier mbs-clearance run wrote them, otherwise `--force` is needed (docs/user_guide.md).

{CLI_HEADING}

{cli_table(cli_rows)}

{LIBRARY_HEADING}

`M = SliderCrank()` (the paper's case); `crafted(...)` writes a trajectory file of one
revolution with one thing changed; a case running longer than {LIBRARY_TIMEOUT:g} s is stopped.

{library_table(library_rows)}
"""


def cli_section(text: str) -> str:
    """The command-line table of a document."""
    start = text.index(CLI_HEADING)
    return text[start:text.index(LIBRARY_HEADING)].strip()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli-only", action="store_true",
                    help="print the command-line table only (no file written)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, default=DOC, help="default docs/bad_input.md")
    args = ap.parse_args(argv)
    if args.worker:
        _worker()
        return 0
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    cli_rows = run_cli_cases()
    if args.cli_only:
        print(cli_table(cli_rows))
        return 0
    library_rows = run_library_cases()
    args.out.write_text(document(cli_rows, library_rows))
    print(f"{len(cli_rows)} command-line and {len(library_rows)} library cases written to "
          f"{args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
