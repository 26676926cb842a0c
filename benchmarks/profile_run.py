"""Profile the paper case's peak-only run with `perf`, the compiled functions named.

numba's kernels loaded from the disk cache have no symbols that perf can see: perf reports
them as anonymous "[JIT]" addresses. This script writes perf's map of JIT symbols
(/tmp/perf-<pid>.map, "start size name" per line) for the kernels of the generated paper
model's `integrate_model` (the integrator's stages `_attempt`, `_find_event`, ... linked
into it) and of its `rhs`, `event` and `monitor`: their addresses are read from the
object code in the cache files (nm) and placed by one symbol whose runtime address numba
gives. Then it runs the case `--repeats` times. Use it under perf:

    perf record -F 10000 -o /tmp/perf.data python -m benchmarks.profile_run [--ddm]
    perf report -i /tmp/perf.data --sort sym

(``--ddm``: the DDM of the 8 default parameters, `sensitivities(mech)`, instead.)

The map is for numba's kernels: run with ``MBS_CLEARANCE_CORE=numba``. On the C core (the
default, for plain and DDM runs alike) perf names the compiled functions by itself.

(the Python start-up and import are in the profile too; compare the kernels' shares
with each other).
"""

from __future__ import annotations

import argparse
import os
import struct
import subprocess
import tempfile
import time
from pathlib import Path

from mbs_clearance import SliderCrank, peak_base_force
from mbs_clearance.solve import reduced


def _elf_objects(blob: bytes):
    """The ELF object files inside a numba cache file (a pickle holding their bytes)."""
    i = 0
    while True:
        i = blob.find(b"\x7fELF", i)
        if i < 0:
            return
        shoff, = struct.unpack_from("<Q", blob, i + 0x28)
        shentsize, shnum = struct.unpack_from("<HH", blob, i + 0x3A)
        end = i + shoff + shentsize * shnum
        yield blob[i:end]
        i = end


def _symbols(dispatcher, cache_file: Path) -> list[str]:
    """perf map lines of the functions in the object code of `cache_file`, placed by the
    first of them whose address the dispatcher's loaded libraries resolve."""
    libs = [cres.library for cres in dispatcher.overloads.values()]
    lines = []
    for obj in _elf_objects(cache_file.read_bytes()):
        with tempfile.NamedTemporaryFile(suffix=".o") as fh:
            fh.write(obj)
            fh.flush()
            out = subprocess.run(["nm", "-S", "--defined-only", fh.name], capture_output=True,
                                 text=True, check=True).stdout
        syms = []
        base = None
        for line in out.splitlines():
            parts = line.split()
            if len(parts) != 4 or parts[2] not in "tTW":
                continue
            value, size, name = int(parts[0], 16), int(parts[1], 16), parts[3]
            syms.append((value, size, name))
            for lib in libs if base is None else ():
                try:
                    addr = lib.get_pointer_to_function(name)
                except Exception:       # not in this library
                    addr = 0
                if addr:
                    base = addr - value
                    break
        if base is None:
            continue
        names = subprocess.run(["c++filt"], input="\n".join(s[2] for s in syms),
                               capture_output=True, text=True).stdout.splitlines()
        for (value, size, _), name in zip(syms, names):
            lines.append(f"{base + value:x} {size:x} {name.split('[')[0]}")
    return lines


#: the kernels named in the map: of the plain run, of the DDM run (``--ddm``)
KERNELS = ("integrate_model", "rhs", "event", "monitor")
DDM_KERNELS = ("integrate_sens", "rhs_sens", "monitor_sens", "on_event_sens", "tangent",
               "event")


def write_perf_map(names=KERNELS) -> int:
    """Write /tmp/perf-<pid>.map for the paper model's kernels; returns the symbols."""
    model = reduced.MODEL
    cache = Path(model.__file__).parent / "__pycache__"
    stem = Path(model.__file__).stem
    lines = []
    for name in names:
        files = sorted(cache.glob(f"nb-*/{stem}.{name}-*.nbc"), key=os.path.getmtime)
        if files:
            lines += _symbols(getattr(model, name), files[-1])    # the newest: this digest's
    Path(f"/tmp/perf-{os.getpid()}.map").write_text("\n".join(lines) + "\n")
    return len(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=300)
    ap.add_argument("--ddm", action="store_true",
                    help="profile the DDM of the 8 default parameters (`sensitivities(mech)`)")
    args = ap.parse_args(argv)
    mech = SliderCrank()
    if args.ddm:
        from mbs_clearance.analysis.sensitivity import sensitivities

        def work():
            return sensitivities(mech)
    else:
        def work():
            return peak_base_force(mech, 4)
    work()                                   # load (or compile) the kernels
    n = write_perf_map(DDM_KERNELS if args.ddm else KERNELS)
    print(f"{n} symbols in /tmp/perf-{os.getpid()}.map", flush=True)
    t0 = time.process_time()
    for _ in range(args.repeats):
        work()
    print(f"{1e3 * (time.process_time() - t0) / args.repeats:.3f} ms CPU per run")


if __name__ == "__main__":
    main()
