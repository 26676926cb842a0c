"""Start-up time of the library and the command line, in fresh processes.

Each command runs as a new Python process in the checkout's root (its `mbs_clearance`
shadows an installed one):

- ``import``: ``python -c "import mbs_clearance"``;
- ``help``: ``python -m mbs_clearance.cli --help``;
- ``simulate_help``: ``python -m mbs_clearance.cli simulate --help``;
- ``simulate``: ``python -m mbs_clearance.cli simulate`` (the paper's case, 4 revolutions,
  warm: the core and the model load from the compiled-code cache, which the untimed warm-up
  run fills).

One untimed warm-up run of each command first (per checkout: it fills the bytecode and
compiled-code caches), then `--repeats` rounds, each running the commands in rotation (import, help,
simulate_help, simulate, import, ...), so that a change of the machine's load hits every
command alike; the median wall time of each command is printed.

With ``--vs PATH`` (another checkout, e.g. a worktree of an earlier version: ``git worktree
add /tmp/before REV``) every command of a round runs in both
checkouts as a pair, in alternating order (this, other; then other, this), and the median of
the per-pair ratios other / this is printed: the ratio of each pair is taken under the same
load, so a noisy machine widens its spread, not its median.

    python -m benchmarks.startup [--repeats 11] [--vs PATH] [--json]
    python -m benchmarks.startup --cold integrator simulate simulate_four_bar sensitivity
    python -m benchmarks.startup --cold simulate new_description lyapunov orbits map --again

``--cold`` instead runs the given commands once each, in order, in a fresh copy of the
package (an empty compiled-code cache, as on a fresh install), and prints each
one's wall and CPU time: the first answer a new user waits for. CPU time is the measure
on a busy machine. ``--again`` then runs each once more, warm, and prints what the first
run cost beyond it. ``new_description`` is a description of a structure no model ships
for (the documented four-bar with its crank-coupler joint loose too), written as data.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from validation.timing import machine_summary

#: name -> arguments after the Python executable
COMMANDS = {
    "import": ["-c", "import mbs_clearance"],
    "help": ["-m", "mbs_clearance.cli", "--help"],
    "simulate_help": ["-m", "mbs_clearance.cli", "simulate", "--help"],
    "simulate": ["-m", "mbs_clearance.cli", "simulate"],
}

#: what --cold runs, in this order, in one fresh copy of the package: the integrator alone
#: (specialised for a 3-state linear system: the floor of any model's first compilation),
#: then the first commands of a new user
COLD_COMMANDS = {
    "integrator": ["-c", "from mbs_clearance.analysis.lyapunov import textbook_exponent as t; "
                         "t('linear', 1.0, matrix=[[-1, 0, 0], [0, -2, 0], [0, 0, -3]])"],
    "simulate": ["-m", "mbs_clearance.cli", "simulate"],
    "simulate_four_bar": ["-m", "mbs_clearance.cli", "simulate", "--case", "four_bar"],
    "sensitivity": ["-m", "mbs_clearance.cli", "sensitivity"],
    # a description of a structure no model ships for (the documented four-bar with a second
    # clearance joint), written as data: generated and compiled on its first run
    "new_description": ["-m", "mbs_clearance.cli", "simulate", "--description",
                        "new_structure.json", "--revolutions", "3"],
    "custom_linkage": ["EXAMPLE", "custom_linkage.py"],
    "lyapunov": ["-m", "mbs_clearance.cli", "lyapunov", "--revolutions", "20"],
    "orbits": ["-m", "mbs_clearance.cli", "orbits"],
    "map": ["-m", "mbs_clearance.cli", "map", "--sweep", "clearance=1e-5:1e-4:3",
            "--revolutions", "20", "--keep", "17"],
    "animate": ["-m", "mbs_clearance.cli", "animate", "--out", "animation.gif"],
}


def _new_structure(folder: Path) -> None:
    """Write new_structure.json into `folder`: examples/my_four_bar.json with its
    crank-coupler joint loose too (a structure of its own)."""
    lk = json.loads((ROOT / "examples" / "my_four_bar.json").read_text())
    joint = next(j for j in lk["joints"] if j["name"] == "crank_coupler")
    lk["joints"].remove(joint)
    lk["clearance_joints"].append({
        "name": "crank_coupler", "journal_body": joint["body_a"],
        "journal_point": joint["point_a"], "bearing_body": joint["body_b"],
        "bearing_point": joint["point_b"], "bearing_radius": 0.01,
        "journal_radius": 0.0099, "restitution": 0.8})
    lk["name"] = "new_structure"
    (folder / "new_structure.json").write_text(json.dumps(lk, indent=1))


def _argv(name: str) -> list[str]:
    cmd = COLD_COMMANDS[name]
    if cmd[0] == "EXAMPLE":
        return [sys.executable, str(ROOT / "examples" / cmd[1])]
    return [sys.executable, *cmd]

ROOT = Path(__file__).resolve().parents[1]


def checkout(path: str | Path) -> Path:
    """The root of a checkout (a folder holding mbs_clearance/__init__.py); ValueError
    otherwise."""
    root = Path(path).resolve()
    if not (root / "mbs_clearance" / "__init__.py").is_file():
        raise ValueError(f"--vs must be a checkout of mbs-clearance (a folder with "
                         f"mbs_clearance/__init__.py); got {str(path)!r}")
    return root


def run_once(root: Path, name: str) -> float:
    """Wall time in s of one fresh process running command `name` in checkout `root`;
    RuntimeError if it fails."""
    env = dict(os.environ, PYTHONPATH=str(root))
    env.pop("MBS_CLEARANCE_DEBUG", None)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *COMMANDS[name]], cwd=root, env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{name} failed in {root} (status {proc.returncode}): "
                           f"{proc.stderr.strip().splitlines()[-1:] or ''}")
    return elapsed


def measure(repeats: int, other: Path | None = None, names=tuple(COMMANDS)) -> dict:
    """Median wall times (s) of each command in this checkout and, with `other`, in that one
    and the median of the per-pair ratios other / this."""
    roots = [ROOT] + ([other] if other is not None else [])
    for root in roots:                                 # warm-up: caches filled, not timed
        for name in names:
            run_once(root, name)
    times = [{n: [] for n in names} for _ in roots]     # by checkout: this, other
    for k in range(repeats):
        for name in names:
            order = range(len(roots)) if k % 2 == 0 else reversed(range(len(roots)))
            for i in order:
                times[i][name].append(run_once(roots[i], name))
    out = {"repeats": repeats, "machine": machine_summary(), "this": str(ROOT),
           "median_s": {n: float(np.median(times[0][n])) for n in names}}
    if other is not None:
        out["other"] = str(other)
        out["other_median_s"] = {n: float(np.median(times[1][n])) for n in names}
        out["ratio_other_over_this"] = {
            n: float(np.median(np.asarray(times[1][n]) / np.asarray(times[0][n])))
            for n in names}
    return out


def cold(names=tuple(COLD_COMMANDS), again: bool = False) -> dict:
    """Wall and CPU time (s) of each of `names`, run once and in order in a fresh copy of
    the package (its compiled-code cache empty, as on a fresh install): the first
    is a cold start, each later one pays for what the ones before it did not compile.
    With `again`, each is then run a second time (warm: everything built), and both
    times are kept."""
    import resource
    import shutil
    import tempfile

    rows = {}
    with tempfile.TemporaryDirectory(prefix="mbs-cold-") as tmp:
        shutil.copytree(ROOT / "mbs_clearance", Path(tmp) / "mbs_clearance",
                        ignore=shutil.ignore_patterns("__pycache__"))
        env = {k: v for k, v in os.environ.items()
               if k not in ("PYTHONPATH", "MBS_CLEARANCE_DEBUG")}
        env["PYTHONPATH"] = tmp
        # the compiled core's and the models' libraries: an empty cache too
        env["MBS_CLEARANCE_CACHE_DIR"] = str(Path(tmp) / "compiled")
        env["XDG_CACHE_HOME"] = str(Path(tmp) / "xdg")
        _new_structure(Path(tmp))
        for rounds, key in ((names, ""), (names if again else (), "warm_")):
            for name in rounds:
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                proc = subprocess.run(_argv(name), cwd=tmp, env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                      text=True)
                wall = time.perf_counter() - t0
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                if proc.returncode != 0:
                    raise RuntimeError(f"{name} failed (status {proc.returncode}): "
                                       f"{proc.stderr.strip().splitlines()[-1:] or ''}")
                rows.setdefault(name, {}).update({
                    f"{key}wall_s": wall,
                    f"{key}cpu_s": (after.ru_utime - before.ru_utime
                                    + after.ru_stime - before.ru_stime)})
    return {"machine": machine_summary(), "cold": rows}


def report_cold(result: dict) -> str:
    again = all("warm_wall_s" in r for r in result["cold"].values())
    lines = [f"first runs in a fresh copy of the package, compiled-code cache empty "
             f"({result['machine']})", f"{'command':<18} {'wall (s)':>9} {'CPU (s)':>9}"
             + (f" {'warm wall':>10} {'warm CPU':>9} {'first - warm':>13}" if again else "")]
    for n, r in result["cold"].items():
        line = f"{n:<18} {r['wall_s']:>9.1f} {r['cpu_s']:>9.1f}"
        if again:
            line += (f" {r['warm_wall_s']:>10.1f} {r['warm_cpu_s']:>9.1f} "
                     f"{r['wall_s'] - r['warm_wall_s']:>+13.1f}")
        lines.append(line)
    return "\n".join(lines)


def report(result: dict) -> str:
    lines = [f"start-up in fresh processes, median of {result['repeats']} rounds "
             f"({result['machine']})", f"this checkout: {result['this']}"]
    if "other" in result:
        lines.append(f"other checkout: {result['other']}")
        lines.append(f"{'command':<15} {'this (s)':>10} {'other (s)':>10} "
                     f"{'other / this':>13}")
        for n, t in result["median_s"].items():
            lines.append(f"{n:<15} {t:>10.3f} {result['other_median_s'][n]:>10.3f} "
                         f"{result['ratio_other_over_this'][n]:>13.2f}")
    else:
        lines.append(f"{'command':<15} {'this (s)':>10}")
        for n, t in result["median_s"].items():
            lines.append(f"{n:<15} {t:>10.3f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=11,
                        help="timed rounds (default 11)")
    parser.add_argument("--vs", metavar="PATH",
                        help="another checkout timed in alternating pairs (default: none)")
    parser.add_argument("--only", nargs="+", choices=list(COMMANDS), default=list(COMMANDS),
                        help="commands timed (default: all)")
    parser.add_argument("--cold", nargs="+", choices=list(COLD_COMMANDS), metavar="COMMAND",
                        help="instead: run these once, in order, in a fresh copy of the "
                             "package with an empty compiled-code cache (choices: "
                             f"{', '.join(COLD_COMMANDS)})")
    parser.add_argument("--again", action="store_true",
                        help="with --cold: then run each command once more, warm, and print "
                             "the first run's extra time")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    args = parser.parse_args(argv)
    if args.cold:
        result = cold(tuple(args.cold), args.again)
        print(json.dumps(result, indent=2) if args.json else report_cold(result))
        return 0
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; got {args.repeats}")
    try:
        other = None if args.vs is None else checkout(args.vs)
    except ValueError as exc:
        parser.error(str(exc))
    result = measure(args.repeats, other, tuple(args.only))
    print(json.dumps(result, indent=2) if args.json else report(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
