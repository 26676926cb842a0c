"""Command line: `mbs-clearance SUBCOMMAND ...`; each subcommand calls a public function.

Errors: every failure a user can cause ends with one line ``mbs-clearance CMD: error: CAUSE``
on stderr and a non-zero exit status: 2 for bad input (argparse's usage errors, ValueError:
bad values, unusable output paths), 1 for failures while running (RuntimeError, OSError),
130 after Ctrl-C. Any other exception is a bug: one line saying so, and the traceback with
``MBS_CLEARANCE_DEBUG=1``. Output paths are checked before any computation and results are
written atomically (see `mbs_clearance._io`).
"""

from __future__ import annotations

import argparse
import cmath
import dataclasses
import json
import logging
import math
import os
import re
import sys
import time
import traceback
import warnings
from pathlib import Path

from ._io import OutputDir, atomic_file, check_output_dir, check_output_file, folder_lock
from .model.mechanism import PARAMETER_INFO, SliderCrank
from .units import number, parse_quantity, quantity, unit_of_path

# the subcommands import what they need when they run (start-up time): simulate, optimize,
# sensitivity, the plotting and the validation plugins are not imported to build the parser

#: the backends and integrators offered (checked again by the library when it runs)
BACKEND_NAMES = ("exudyn", "ideal", "reduced")
MASS_SCALING_NAMES = ("fixed", "uniform")

__all__ = ["main", "build_parser", "mechanism_from_args", "linkage_from_args",
           "add_mechanism_options", "case_override",
           "format_table3", "run_command", "Parser", "int_at_least", "positive_float",
           "finite_float", "quantity_type", "add_force_option", "HelpFormatter", "wrote"]

#: environment variable that makes unexpected errors show their traceback
DEBUG_ENV = "MBS_CLEARANCE_DEBUG"


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """--help that shows every option's default (unless its text already says it), "(required)"
    for required options, the choices that a metavar hides, and keeps the descriptions' and
    epilogs' line breaks (each line wrapped to the terminal's width)."""

    def _fill_text(self, text, width, indent):
        import textwrap

        return "\n".join(textwrap.fill(line, width, initial_indent=indent,
                                        subsequent_indent=indent + ("  " if line.startswith(
                                            "  ") else "")) if line.strip() else ""
                         for line in text.splitlines())

    def _get_default_metavar_for_optional(self, action):
        # a value's kind rather than the option's name in capitals (--out OUT, --rtol RTOL)
        kind = getattr(action.type, "__name__", "")
        if kind.startswith("integer"):
            return "N"
        if kind in ("positive_float", "finite_float", "float", "quantity"):
            return "X"
        if action.type is Path or kind in ("Path", "PosixPath", "WindowsPath"):
            return "PATH"
        return super()._get_default_metavar_for_optional(action)

    def _get_help_string(self, action):
        text = action.help or ""
        if not action.option_strings or text == argparse.SUPPRESS:
            return text
        if action.choices is not None and action.metavar is not None and \
                not all(str(c) in text for c in action.choices):
            text += f" (choices: {', '.join(str(c) for c in action.choices)})"
        if "default" in text or action.nargs == 0:
            return text
        if action.required:
            return f"{text} (required)"
        default = action.default
        if default is None or default is argparse.SUPPRESS:
            default = "none"
        elif isinstance(default, (list, tuple)):
            default = " ".join(str(v) for v in default)
        return f"{text} (default: {str(default).replace('%', '%%')})"


#: options that a short --help leaves to --help-all: the settings of the solvers and
#: backends, the start, and the free linkages' time options
ADVANCED_OPTIONS = frozenset({
    "settled", "rtol", "step_size", "integrator", "contact", "duration", "window", "force",
    "config", "dask_timeout", "saturation_rtol", "retries", "write_interval", "chunk_size",
    "max_memory",
})
#: title of the argument groups whose options are all left to --help-all
ADVANCED_GROUP_PREFIX = "mechanism"


class _HelpAll(argparse.Action):
    """--help-all: the full help page (every option, in groups) and exit."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        parser.print_help(full=True)
        parser.exit()


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line: ``PROG: error: MESSAGE`` (status 2),
    and that reads ``--rtol -1e-8`` as a (negative) value, not as an option. Its --help
    shows the common options with their defaults (`HelpFormatter`); --help-all shows every
    option, the common ones first."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)
        # argparse's own pattern misses exponents (-1e-8) and would report "expected one
        # argument"; the value then reaches the option's check and its clear message
        self._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
        if self.add_help:
            self.add_argument("--help-all", action=_HelpAll,
                              help="show every option and exit")

    def _advanced(self, action, group) -> bool:
        if group.title and group.title.startswith(ADVANCED_GROUP_PREFIX):
            return action.dest != "clearance"
        return action.dest in ADVANCED_OPTIONS or getattr(action, "advanced", False)

    def print_help(self, file=None, full: bool = False):
        self._full_help = full
        try:
            super().print_help(file)
        finally:
            self._full_help = False

    def format_help(self) -> str:
        full = getattr(self, "_full_help", False)
        groups = [(g, [a for a in g._group_actions if not self._advanced(a, g)],
                   [a for a in g._group_actions if self._advanced(a, g)])
                  for g in self._action_groups]
        hidden = sum(len(more) for _, _, more in groups)
        if not hidden:
            return super().format_help()
        formatter = self._get_formatter()
        common = [a for g, c, _ in groups for a in c]
        formatter.add_usage(self.usage, common, self._mutually_exclusive_groups)
        formatter.add_text(self.description)
        for g, c, _ in groups:
            formatter.start_section(g.title)
            formatter.add_text(g.description)
            formatter.add_arguments(c)
            formatter.end_section()
        if full:
            more = [a for g, _, m in groups if not g.title.startswith(ADVANCED_GROUP_PREFIX)
                    for a in m]
            formatter.start_section("solver, backend and output settings")
            formatter.add_arguments(more)
            formatter.end_section()
            for g, _, m in groups:
                if m and g.title.startswith(ADVANCED_GROUP_PREFIX):
                    formatter.start_section(g.title)
                    formatter.add_arguments(m)
                    formatter.end_section()
            formatter.add_text(self.epilog)
        else:
            formatter.add_text(f"{hidden} more options (mechanism values in SI units, solver "
                               f"and backend settings, --force; the named cases described): "
                               f"{self.prog} --help-all")
        return formatter.format_help()

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {_one_line(message)}\n")


def leave_to_help_all(parser: argparse.ArgumentParser, *dests: str) -> None:
    """Show the options `dests` (their dest names) under --help-all only, for this parser
    (`ADVANCED_OPTIONS` holds those of every command)."""
    missing = sorted(set(dests) - {a.dest for a in parser._actions})
    if missing:
        raise ValueError(f"no option(s) {missing} to leave to --help-all")
    for action in parser._actions:
        if action.dest in dests:
            action.advanced = True


def _one_line(text: str) -> str:
    return "; ".join(line.strip() for line in str(text).splitlines() if line.strip())


def wrote(path, what: str) -> None:
    """Say where a file or folder was written: ``wrote FILE (WHAT)`` on stderr."""
    print(f"wrote {path} ({what})", file=sys.stderr, flush=True)


def write_file(path, write, what: str) -> None:
    """`write`(a temporary path beside `path`), moved into place when it succeeds, then said
    (`wrote`)."""
    with atomic_file(path) as tmp:
        write(tmp)
    wrote(path, what)


class _CliLogHandler(logging.Handler):
    """The library's messages (logger "mbs_clearance") on stderr, one line each, while a
    command runs: ``PROG: MESSAGE``. Notes (INFO: "compiling kernels ...") on an interactive
    terminal only, like `_progress`, so that a failed run's error stays its only line;
    warnings always."""

    def __init__(self, prog: str):
        super().__init__(logging.INFO if sys.stderr.isatty() else logging.WARNING)
        self.prog = prog

    def emit(self, record):
        try:
            sys.stderr.write(f"{self.prog}: {_one_line(record.getMessage())}\n")
            sys.stderr.flush()
        except Exception:  # noqa: BLE001 - logging must never break the command
            self.handleError(record)


def run_command(prog: str, func, args: argparse.Namespace) -> int:
    """Run a subcommand; a failure ends the process (SystemExit) after one line on stderr.

    ValueError (bad input) gives status 2, RuntimeError and OSError (failures while running)
    status 1, KeyboardInterrupt 130; anything else is reported as an internal error (status
    1), with the traceback when the environment variable MBS_CLEARANCE_DEBUG is set. Warnings
    shown while it runs are one line as well, ``PROG: warning: MESSAGE``.
    """
    debug = os.environ.get(DEBUG_ENV, "") not in ("", "0")
    formatwarning = warnings.formatwarning
    logger = logging.getLogger("mbs_clearance")
    handler = _CliLogHandler(prog)
    logger.addHandler(handler)
    level = logger.level
    if logger.level == logging.NOTSET or logger.level > logging.INFO:
        logger.setLevel(logging.INFO)
    if not debug:   # warnings as one line too: "PROG: warning: MESSAGE"
        warnings.formatwarning = lambda message, category, *rest, **kw: (
            f"{prog}: warning: {_one_line(message)}\n")
    from .studies.executor import _sigterm_raises

    try:
        # SIGTERM unwinds like Ctrl-C (exit status 143): partial outputs are removed
        with _sigterm_raises():
            return func(args)
    except BaseException as exc:  # noqa: BLE001 - sorted below; SystemExit passes through
        if isinstance(exc, SystemExit):
            raise
        error = exc
    finally:
        warnings.formatwarning = formatwarning
        logger.removeHandler(handler)
        logger.setLevel(level)
    if isinstance(error, KeyboardInterrupt):
        code, message = 130, "interrupted"
    elif isinstance(error, ValueError):
        code, message = 2, _one_line(error)
    elif isinstance(error, OSError) and error.strerror:
        code = 1
        message = error.strerror + ("" if error.filename is None
                                    else f": {str(error.filename)!r}")
    elif isinstance(error, MemoryError):
        code, message = 1, f"out of memory {_one_line(error)}".strip()
    elif isinstance(error, (RuntimeError, OSError)):
        code, message = 1, _one_line(error) or type(error).__name__
    elif isinstance(error, Exception):   # a bug: say so in one line, traceback on demand
        code = 1
        message = (f"internal error {type(error).__name__}: {_one_line(error)} (a bug; rerun "
                   f"with {DEBUG_ENV}=1 for the traceback and report it)")
    else:                                # GeneratorExit and the like: not ours to handle
        raise error
    if debug:
        traceback.print_exception(error)
    sys.stderr.write(f"{prog}: error: {message}\n")
    sys.stderr.flush()
    raise SystemExit(code)


def int_at_least(low: int):
    """argparse type: an integer >= `low`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be an integer >= {low}; got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}; got {value}")
        return value

    parse.__name__ = f"integer >= {low}"
    return parse


def finite_float(text: str) -> float:
    """argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0; got {text!r}")
    return value


def quantity_type(unit: str | None, low: float | None = None, derived: bool = False):
    """argparse type: a finite number in SI `unit`, or with one of the unit's suffixes
    (`units.UNIT_SUFFIXES`: "5000rpm", "0.02mm", "90deg"); with `low`, > low; with
    `derived`, also "none" (the field's derived value, `DERIVED`). ``type.unit`` is `unit`."""

    def parse(text: str):
        if derived and text.strip().lower() == "none":
            return DERIVED
        try:
            value = parse_quantity(text, unit, "value")
        except ValueError as exc:
            why = str(exc).removeprefix("value: ")
            raise argparse.ArgumentTypeError(
                why + ("; or 'none' (the derived value)" if derived else "")) from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
        if low is not None and not value > low:
            raise argparse.ArgumentTypeError(f"must be a finite number > {low:g}; got "
                                             f"{text!r}")
        return value

    parse.__name__ = "quantity"
    parse.unit = unit
    return parse


#: argparse types of the quantities the options take (each also with its unit's suffixes)
length_type = quantity_type("m")
angle_type = quantity_type("rad")
positive_time = quantity_type("s", 0.0)


def add_evaluation_options(parser: argparse.ArgumentParser, out: str,
                           accuracy: bool = False) -> None:
    """Options of a subcommand that evaluates many designs: --rtol (and with `accuracy`
    --accuracy), --scheduler, --workers, --out (default ./`out`) and --no-progress (read by
    `evaluate_on`)."""
    parser.add_argument("--rtol", type=positive_float,
                        help="relative tolerance of the reduced model (default: the model's, "
                             "1e-7)")
    if accuracy:
        parser.add_argument("--accuracy", type=positive_float,
                            help="requested relative accuracy of each design's output "
                                 "instead of a fixed --rtol: each run estimates its own "
                                 "error and tightens until it is within (costs more runs)")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="evaluate on this dask.distributed scheduler (default: none, a "
                             "local pool)")
    parser.add_argument("--workers", type=int_at_least(1), default=2,
                        help="local worker threads when no --scheduler (1 = this process)")
    parser.add_argument("--out", type=Path, default=Path(out),
                        help=f"output folder (default ./{out}, named after the command)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_keep_going_option(parser: argparse.ArgumentParser, what: str) -> None:
    """--keep-going: exit 0 although some of the command's runs failed."""
    parser.add_argument("--keep-going", action="store_true",
                        help=f"exit with status 0 although some {what} failed (by default "
                             f"a failed run makes the exit status 1, after the results of "
                             f"the others are printed and written)")


def refuse_failed_runs(args: argparse.Namespace, failed: int, total: int,
                       what: str = "runs") -> None:
    """RuntimeError (exit status 1) where `failed` of `total` runs failed, unless
    --keep-going; called after the results are written."""
    if failed and not getattr(args, "keep_going", False):
        raise RuntimeError(f"{failed} of {total} {what} failed (the results above leave them "
                           f"out); give --keep-going to accept that with exit status 0")


def evaluate_on(args: argparse.Namespace, fn, *fn_args, **kw):
    """Call fn(*fn_args, executor=..., **kw) on the executor the options of
    `add_evaluation_options` choose: the dask scheduler, this process (--workers 1) or a
    local pool of --workers."""
    if args.scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError as exc:
            raise ValueError("--scheduler needs dask.distributed: "
                             "pip install 'mbs-clearance[dask]'") from exc
        from .studies.optimize import connect_dask

        with connect_dask(args.scheduler) as client:
            print(f"evaluating on the dask cluster at {args.scheduler}", file=sys.stderr)
            return fn(*fn_args, executor=client, **kw)
    if args.workers == 1:
        return fn(*fn_args, executor="serial", **kw)
    return fn(*fn_args, workers=args.workers, **kw)


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """--force: overwrite output files or folders that mbs-clearance did not write."""
    parser.add_argument("--force", action="store_true",
                        help="overwrite an existing output that mbs-clearance did not write "
                             "(by default only files and folders of earlier runs are "
                             "replaced)")


class _Derived:
    """Value of a mechanism option given as ``none``: the field's derived value (None)."""

    def __repr__(self) -> str:
        return "none"


DERIVED = _Derived()


def add_mechanism_options(parser: argparse.ArgumentParser) -> None:
    """One option per SliderCrank field (--crank-length ...) plus --config FILE.json."""
    group = parser.add_argument_group(
        "mechanism (SI, or with a unit: 50mm, 5000rpm, 90deg; defaults: the paper's case)")
    group.add_argument("--config", metavar="FILE.json",
                       help="JSON object of SliderCrank fields; options below override it "
                            "(default: none, the paper's values)")
    group.add_argument("--clearance", type=length_type, default=None, metavar="X",
                       help="radial clearance of the clearance joint(s) in m, the same as "
                            "--set clearance=X (default: the case's; the paper's 0.01 mm)")
    defaults = SliderCrank()
    for f in dataclasses.fields(SliderCrank):
        symbol, unit, _ = PARAMETER_INFO[f.name]
        default = getattr(defaults, f.name)
        optional = default is None or f.name.endswith("inertia")
        kind = (str if f.name in ("contact_model", "friction_law")
                else quantity_type(unit, derived=optional))
        extra = "; 'none': derived value" if optional else ""
        if f.name == "contact_model":
            from .laws.forces import CONTACT_MODELS

            shown = f"{default}; one of {', '.join(CONTACT_MODELS)}"
        elif f.name == "friction_law":
            from .laws.forces import FRICTION_LAWS

            shown = f"{default}; one of {', '.join(FRICTION_LAWS)}"
        elif default is None:
            shown = "derived"
        else:
            shown = quantity(default, unit, 6)
            if shown != f"{default:g} {unit}".strip() and unit not in ("-", ""):
                shown += f" = {default:g}"
        if symbol in ("-", ""):
            what = f.name.replace("_", " ")
        else:
            what = symbol + (", dimensionless" if unit in ("-", "") else f" in {unit}")
        group.add_argument("--" + f.name.replace("_", "-"), dest=f.name, type=kind,
                           default=None, metavar="X",
                           help=f"{what} (default {shown}{extra})")


def mechanism_from_args(args: argparse.Namespace) -> SliderCrank:
    """SliderCrank from --config, the per-field options and --set (ValueError on bad values).

    The per-field options are aliases of --set NAME=VALUE; ``none`` sets a field to None (the
    derived value), also over a value from the config file. --clearance (or --set
    clearance=X) sets the journal radius to the bearing radius minus X.
    """
    base = SliderCrank.from_json(args.config) if getattr(args, "config", None) else SliderCrank()
    changes = _mechanism_changes(args, field_unit(None))
    clearance = changes.pop("clearance", None)
    unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(SliderCrank)})
    if unknown:
        raise ValueError(f"--set {unknown[0]}: not a field of the paper's slider-crank; "
                         f"allowed: {', '.join(f.name for f in dataclasses.fields(SliderCrank))}"
                         f", clearance")
    mech = base.replace(**changes)
    if clearance is not None:
        if not isinstance(clearance, float) or not 0.0 < clearance < mech.bearing_radius:
            raise ValueError(f"clearance must be in (0, bearing_radius {mech.bearing_radius!r} "
                             f"m); got {clearance!r}")
        mech = mech.replace(journal_radius=mech.bearing_radius - clearance)
    return mech


def _mechanism_changes(args: argparse.Namespace, unit_of) -> dict:
    """NAME -> value of the per-field options (--crank-length ..., --clearance) and --set,
    one dictionary: the options are aliases of --set. A --set value with a unit suffix is
    converted to SI, its unit checked against the field's (`unit_of(NAME)`, None: unknown).
    ValueError for a name given twice or a suffix of another unit."""
    changes: dict = {}
    for f in dataclasses.fields(SliderCrank):
        value = getattr(args, f.name, None)
        if value is not None:
            changes[f.name] = None if value is DERIVED else value
    if getattr(args, "clearance", None) is not None:
        changes["clearance"] = args.clearance
    options = set(changes)
    for name, value in getattr(args, "set", None) or []:
        if name in options:
            option = "--" + name.replace("_", "-")
            raise ValueError(f"{name} given twice: {option} is --set {name}; give one")
        if name in changes:
            raise ValueError(f"--set {name} given twice")
        changes[name] = si_value(f"--set {name}", value, unit_of(name))
    return changes


class Suffixed(str):
    """A command-line value with a unit suffix ("5000rpm"), kept as text until the unit of
    the field it sets is known (`si_value`)."""


def si_value(item: str, value, unit: str | None):
    """`value` in SI: a `Suffixed` text converted by its suffix, which must be one of
    `unit`'s (None: the suffix alone converts it); anything else as is."""
    if isinstance(value, Suffixed):
        return parse_quantity(str(value), unit, item)
    return value


def field_unit(case: str | None = None, description: bool = False):
    """NAME -> SI unit (or None) of a value set by name: of the paper's slider-crank
    (`case` None and not `description`: its fields), of a named case (its overrides) or of
    a description (its dotted paths), and 'clearance' / '<joint>.clearance' (m)."""
    from .model.mechanism import PARAMETER_INFO

    def unit_of(name: str) -> str | None:
        if name == "clearance" or name.endswith(".clearance"):
            return "m"
        if case is None and not description:
            return PARAMETER_INFO[name][1] if name in PARAMETER_INFO else None
        if case is not None:
            from .model.cases import CASE_PARAMETERS

            if name in CASE_PARAMETERS.get(case, {}):
                return CASE_PARAMETERS[case][name][1]
        return unit_of_path(name)

    return unit_of


def unit_of_args(args: argparse.Namespace):
    """`field_unit` of the mechanism the options --case / --description choose."""
    return field_unit(getattr(args, "case", None),
                      getattr(args, "description", None) is not None)


def _case_lines() -> str:
    """One line per named case: its name and the first line of its docstring."""
    from .model.cases import CASE_SUMMARY, CASES

    return "\n".join(f"  {name}: {CASE_SUMMARY.get(name, '')}" for name in sorted(CASES))


_SUFFIXED = re.compile(r"\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*[^\d\s.].*")


def _override_value(text: str):
    """A --set value: a number, a number with a unit suffix (`Suffixed`, converted once the
    field is known), 'none' (None: the case's derived value) or a word."""
    if text.strip().lower() == "none":
        return None
    try:
        return float(text)
    except ValueError:
        return Suffixed(text) if _SUFFIXED.fullmatch(text) else text


def field_value(text: str):
    """argparse type: a finite number (SI) or a number with a unit suffix (`Suffixed`,
    converted by `si_value` once the field it sets is known)."""
    value = _override_value(text)
    if isinstance(value, Suffixed) or isinstance(value, float) and math.isfinite(value):
        return value
    raise argparse.ArgumentTypeError(f"must be a finite number (SI) or one with a unit "
                                     f"suffix (e.g. 5000rpm, 0.02mm); got {text!r}")


def case_override(text: str) -> tuple[str, object]:
    """argparse type: NAME=VALUE."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"must be NAME=VALUE (an override of the --case, "
                                         f"e.g. clearance=1e-4); got {text!r}")
    return name.strip(), _override_value(value.strip())


def gene_bounds(text: str) -> tuple[str, tuple[float, float]]:
    """argparse type: NAME=LO:HI (a GA gene and its bounds, SI or with a unit suffix:
    `Suffixed`, converted by `_genes` once the gene's unit is known)."""
    name, sep, rhs = text.partition("=")
    lo, sep2, hi = rhs.partition(":")
    bounds = tuple(_override_value(v.strip()) for v in (lo, hi))
    if not (sep and sep2 and name.strip()) or not all(
            isinstance(b, Suffixed) or isinstance(b, float) and math.isfinite(b)
            for b in bounds):
        raise argparse.ArgumentTypeError(f"must be NAME=LO:HI (a gene and its bounds in SI "
                                         f"units or with a unit suffix, e.g. "
                                         f"coupler_length=3.6:4.4 or crank_length=40mm:60mm); "
                                         f"got {text!r}")
    return name.strip(), bounds


def linkage_from_args(args: argparse.Namespace):
    """The `Linkage` of --case NAME or --description FILE with the --set values (and the
    per-field options, aliases of --set), or None when neither is given (the paper's
    SliderCrank then, `mechanism_from_args`). A case's --set names are its overrides (and
    'clearance'); a description's are its dotted paths (`coupler.mass`, 'clearance',
    '<joint>.clearance'). ValueError on bad input."""
    case = getattr(args, "case", None)
    description = getattr(args, "description", None)
    if case is None and description is None:
        return None
    if getattr(args, "config", None):
        raise ValueError(f"--config holds SliderCrank fields, for the paper's slider-crank "
                         f"only, not for --{'case' if case else 'description'}")
    changes = _mechanism_changes(args, unit_of_args(args))
    if description is not None:
        from .model.linkage import Linkage

        linkage = Linkage.from_file(description)
        if not changes:
            return linkage
        from .model.design import linkage_with

        linkage = linkage_with(linkage, changes)
    else:
        from .model.cases import CASES

        linkage = CASES[case](**changes)
    if changes:
        linkage.assemble()      # values that cannot close the loops: refused before any work
    return linkage


def design_from_args(args: argparse.Namespace):
    """(linkage, design): the `Linkage` of --case / --description (`linkage_from_args`) as
    both, or (None, the SliderCrank of the mechanism options)."""
    linkage = linkage_from_args(args)
    return linkage, linkage if linkage is not None else mechanism_from_args(args)


def _progress(message: str) -> None:
    """A note that work starts, on an interactive terminal only (so that an error raised by
    the work stays the only line a failed run prints)."""
    if sys.stderr.isatty():
        print(message, file=sys.stderr, flush=True)


#: the note under the per-revolution tables (their revolution 1 is marked *)
START_UP_NOTE = ("* revolution 1 is the start-up transient (the journal starts centred with "
                 "ideal-joint velocities)")
#: what the paper's case adds to it
PAPER_NOTE = "; the paper reports revolution 4"


def _revolution_label(k: int, transient: bool = True) -> str:
    return f"{k}*" if k == 1 and transient else str(k)


def _force(value: float) -> str:
    # six significant digits: the default run's relative accuracy is 1e-5
    return quantity(value, "N", 6)


def run_span(design, args: argparse.Namespace, option: str = "revolutions",
             default: int = 4, what: str = "it runs") -> dict:
    """The span of a command's run as `simulate`'s keywords: the revolutions of a driven
    design (--OPTION, `default` when not given; --duration / --window refused), or a free
    linkage's --duration and --window (--OPTION and --settled refused). Sets
    ``args.OPTION`` to the revolutions (None for a free linkage). ValueError naming the
    option that does not apply."""
    flag = "--" + option
    attr = option.replace("-", "_")
    if getattr(design, "drive", True) is not None:
        refuse_window_options(args, flag)
        if getattr(args, attr) is None:
            setattr(args, attr, default)
        return {"revolutions": getattr(args, attr)}
    settled = " or --settled" if hasattr(args, "settled") else ""
    if getattr(args, attr) is not None or getattr(args, "settled", None) is not None:
        raise ValueError(f"linkage {design.name!r} is free (no drive): {what} --duration "
                         f"seconds (windows of --window), not {flag}{settled}")
    if args.duration is None:
        raise ValueError(f"linkage {design.name!r} is free (no drive): give --duration "
                         "(s) and optionally --window (s)")
    return {"duration": args.duration, "window": args.window}


def _span_rows(traj, span: dict):
    """(label heading, [(label, sample mask, peak of the default output)]) of a run's
    revolutions (the first marked as the start-up transient by the caller) or a free
    linkage's time windows."""

    if "revolutions" in span:
        return "revolution", [(k, traj.revolution_mask(k), traj.max_base_force(k))
                              for k in range(1, traj.revolutions + 1)]
    from .solve.linkage_model import time_edges

    edges = time_edges(span["duration"], span["window"])      # the run's windows
    rows = []
    for k, peak in enumerate(traj.peaks):
        a, b = edges[k], edges[k + 1]
        rows.append((f"{a:.4g}-{b:.4g}", (traj.t >= a) & (traj.t <= b), float(peak)))
    return "window [s]", rows


def _cmd_simulate(args: argparse.Namespace) -> int:
    """simulate: the peaks per revolution (a free linkage: per time window) of the
    mechanism's default output, the drive moment and each contact's force, each column
    headed by its output's name."""
    import numpy as np

    from .solve.simulate import simulate
    from .solve.trajectory import load_trajectory

    linkage, design = design_from_args(args)
    span = run_span(design, args)
    bound_spans(design, args)
    if args.out:
        check_output_file(args.out, "--out", args.force, suffixes=(".npz", ".csv"),
                          reader=load_trajectory)
    if args.plot:
        if linkage is not None:
            raise ValueError("--plot draws the paper's slider-crank only; leave it out with "
                             "--case or --description")
        check_output_file(args.plot, "--plot", args.force, suffixes=figure_suffixes())
    if args.backend == "ideal" and args.settled:
        raise ValueError("--settled needs the reduced or exudyn backend")
    options = _simulate_options(args)
    start = settled_start_of(linkage, args)
    if start is not None:
        options["start"] = start
    name = "the paper's slider-crank" if linkage is None else repr(linkage.name)
    how = (f"{args.revolutions} revolutions" if "revolutions" in span
           else f"(free) for {args.duration:g} s")
    _progress(f"simulating {name}, {how} with backend {args.backend!r} ...")
    t0 = time.perf_counter()
    traj = simulate(design, backend=args.backend, **span, **options)
    print(f"done in {time.perf_counter() - t0:.3g} s ({len(traj.t)} samples)",
          file=sys.stderr)
    refuse_empty(traj, "revolution" if "revolutions" in span else "window")
    warn_absurd_forces(design, traj)
    ideal = args.backend == "ideal"     # no clearance: no contact force
    driven = "revolutions" in span
    contact = np.asarray(traj.contact_force, dtype=float)
    contact = contact[:, None] if contact.ndim == 1 else contact
    joints = [] if ideal else list(traj.joints or ("contact",))[:contact.shape[1]]
    # every column is headed by the name of the output whose peak it shows
    heads = ([f"max {traj.output}"] + (["max drive_moment"] if driven else [])
             + [f"max contact_force:{j}" for j in joints])
    widths = [max(12, len(h)) for h in heads]
    # ideal joints have no journal whose centred start makes a transient
    transient = driven and start is None and not ideal
    label, rows = _span_rows(traj, span)
    lw = 20 if not driven else 10
    print((f"{label:>{lw}}  " + "  ".join(f"{h:>{w}}" for h, w in zip(heads, widths)))
          .rstrip())
    for k, mask, peak in rows:
        cells = [_force(peak)]
        if driven:
            cells.append(quantity(abs(traj.crank_moment[mask]).max(), "N m", 6))
        cells += [_force(contact[mask, i].max()) for i in range(len(joints))]
        first = _revolution_label(k, transient) if driven else k
        print((f"{first:>{lw}}  " + "  ".join(f"{c:>{w}}" for c, w in zip(cells, widths)))
              .rstrip())
    if transient:
        print(START_UP_NOTE + (PAPER_NOTE if linkage is None else ""), file=sys.stderr)
    elif start is not None:
        print(f"revolutions counted from the state after {start.revolutions} revolutions "
              "(--settled)", file=sys.stderr)
    _print_error_estimate(traj)
    floored = traj.stats.get("floored_impacts") if traj.stats else None
    if floored:
        print(f"note: {floored} contact onset(s) at the impact-velocity floor (grazing); the "
              f"damping they set is sensitive to the tolerance: compare with a tighter --rtol",
              file=sys.stderr)
    if args.out:
        write_file(args.out, traj.save, "trajectory")
    if args.plot:
        from .plotting import plot_trajectory

        write_file(args.plot, lambda tmp: plot_trajectory(traj, path=tmp), "figure")
    return 0


#: a peak force this many times the design's load scale (`load_scale`) is warned about:
#: the run did not resolve its contacts (measured: the paper's case peaks at 1.7 times it,
#: the four-bar's start-up transient at 13 times)
ABSURD_FORCE = 1000.0


def load_scale(design) -> float:
    """A force scale of `design` in N (a Linkage or a SliderCrank): over its bodies, mass
    times (|gravity| + rate^2 x the body's extent), the rate being the drive speed (a free
    linkage's rate scale), the extent the largest distance between the body's points (the
    slider-crank: its crank and coupler lengths)."""
    if hasattr(design, "bodies"):
        rate = design.rate_scale
        total = 0.0
        for body in design.bodies:
            pts = list(body.points.values())
            extent = max((math.dist(a, b) for a in pts for b in pts), default=0.0)
            total += body.mass * (abs(design.gravity) + rate**2 * extent)
        return total
    rate2 = design.crank_speed**2
    return (design.crank_mass * (abs(design.gravity) + rate2 * design.crank_length)
            + design.coupler_mass * (abs(design.gravity) + rate2 * design.coupler_length)
            + design.slider_mass * abs(design.gravity))


def warn_absurd_forces(design, traj, option: str = "--step-size or --rtol") -> None:
    """A PhysicsWarning where the run's largest contact or monitored force exceeds
    `ABSURD_FORCE` times the design's `load_scale` (a run that did not resolve its
    contacts: a step or tolerance too coarse)."""
    import numpy as np

    from ._warnings import PhysicsWarning

    forces = [np.asarray(traj.contact_force, dtype=float), np.asarray(traj.peaks, dtype=float)]
    peak = max((float(np.nanmax(f)) for f in forces if f.size), default=0.0)
    scale = load_scale(design if design is not None else SliderCrank())
    if not math.isfinite(peak) or peak > ABSURD_FORCE * scale:
        warnings.warn(f"the largest force of the run, {peak:.3g} N, is {peak / scale:.3g} "
                      f"times the mechanism's load scale ({scale:.3g} N: masses times "
                      f"gravity and drive rate squared times length): not physical; the run "
                      f"did not resolve its contacts (a smaller {option})", PhysicsWarning,
                      stacklevel=2)


def refuse_empty(traj, what: str = "revolution") -> None:
    """RuntimeError where a run returned no complete revolution or window: its table would
    be empty."""
    if len(traj.peaks) == 0 or len(traj.t) < 2:
        raise RuntimeError(f"the run returned no complete {what} ({len(traj.t)} samples); "
                           "nothing to report")


def _print_error_estimate(traj) -> None:
    """The run's estimate of its peaks' error against the requested accuracy (runs to an
    accuracy only)."""
    st = traj.stats or {}
    if st.get("error_estimate") is None:
        return
    if "accuracy_steps" in st:      # Exudyn: a step sequence
        how = (f"step halving, {len(st['accuracy_steps'])} runs down to "
               f"{st['accuracy_steps'][-1]:.3g} s")
        if st.get("onset_errors") is not None:
            share = max(e / abs(float(p)) for e, p in zip(st["onset_errors"], traj.peaks))
            how += f", the onsets' registration {share:.2g} of it"
        elif st.get("onset_note"):
            how += f"; the onsets' registration {st['onset_note']}"
    else:
        how = f"rtol {st['rtol']:g}, {len(st['accuracy_runs'])} runs"
    print(f"estimated relative error of the peaks: {st['error_estimate']:.2g} (requested "
          f"{st['accuracy']:g}, {'met' if st['accuracy_ok'] else 'NOT met'}; {how})",
          file=sys.stderr)


def _tolerances(args: argparse.Namespace) -> dict:
    """--rtol or --accuracy of a study, as keywords (both given: refused)."""
    if args.rtol is not None and getattr(args, "accuracy", None) is not None:
        raise ValueError("give --accuracy or --rtol, not both (--accuracy chooses the "
                         "tolerances)")
    if getattr(args, "accuracy", None) is not None:
        from ._checks import check_real

        return {"accuracy": check_real("--accuracy", args.accuracy, 1e-10, 1e-3)}
    if args.rtol is None:
        return {}
    from ._checks import check_real

    # the runs' own range: refused here once, not as every run failing
    return {"rtol": check_real("--rtol", args.rtol, 1e-14, 1e-2)}


def _simulate_options(args: argparse.Namespace) -> dict:
    options = {}
    for key, name in (("rtol", "rtol"), ("step_size", "step_size"), ("contact", "contact"),
                      ("integrator", "method"), ("accuracy", "accuracy")):
        if getattr(args, key, None) is not None:
            options[name] = getattr(args, key)
    return options


def add_window_options(p: argparse.ArgumentParser, what: str,
                       window: str = "the time windows in s, a whole number of them in "
                                     "--duration (default: one window, the whole run)"
                       ) -> None:
    """--duration S and --window S: a free linkage's run (`what` it gives) and its time
    windows (`window`: what they are)."""
    p.add_argument("--duration", type=positive_time, metavar="S",
                   help=f"a free linkage (no drive; e.g. --case "
                        f"flores_translational_slider_crank) only, instead of the "
                        f"revolutions: the run's duration in s; {what} (default: none)")
    p.add_argument("--window", type=positive_time, metavar="S",
                   help=f"with --duration: {window}")


def refuse_window_options(args: argparse.Namespace, flag: str) -> None:
    """ValueError where a driven linkage was given --duration or --window (`flag`: what it
    takes instead)."""
    if args.duration is not None or args.window is not None:
        raise ValueError("--duration and --window are for a free linkage (no drive, e.g. "
                         f"--case flores_translational_slider_crank); a driven one takes "
                         f"{flag}")


def free_window(linkage, args: argparse.Namespace, revolution: str) -> tuple[int, float | None]:
    """(k, w) of the objective's window from --duration / --window: a free linkage's last
    time window, [(k - 1) w, k w] with k w = --duration (w: --window, default --duration),
    and (the --revolution given or 4, None) for a driven one; ValueError naming the option
    that does not apply."""
    flag = "--" + revolution
    given = getattr(args, revolution)
    free = getattr(linkage, "drive", True) is None
    if not free:
        refuse_window_options(args, flag)
        return (4 if given is None else given), None
    if given is not None:
        raise ValueError(f"linkage {linkage.name!r} is free (no drive): it has no "
                         f"revolutions; give --duration (s) and optionally --window (s) "
                         f"instead of {flag}")
    if args.duration is None:
        raise ValueError(f"linkage {linkage.name!r} is free (no drive): give --duration (s) "
                         "and optionally --window (s); the peak is over the last window")
    window = args.duration if args.window is None else args.window
    k = round(args.duration / window)
    if k < 1 or abs(k * window - args.duration) > 1e-9 * args.duration:
        raise ValueError(f"--duration ({args.duration:g} s) must be a whole number of "
                         f"--window ({window:g} s): the peak is over the last full window")
    return k, window


#: the most integrator steps all the runs of one command may take together (the timed
#: repeats of a benchmark): a hundred times one run's max_steps
MAX_COMMAND_STEPS = 100 * 5_000_000
#: bytes of one frame of an animation held until the file is written (the figure of 10 x
#: 4.2 in at 100 dpi, RGBA; matplotlib's GIF writer keeps every frame)
FRAME_BYTES = 4 * 1000 * 420


def _period(design) -> float:
    """A revolution of `design` in s (a free linkage: its time scale); the paper's
    SliderCrank for None."""
    if design is None:
        design = SliderCrank()
    drive = getattr(design, "drive", True)
    return design.period if drive is not None else design.time_scale


def check_run_size(design, option: str, value, *, unit: str = "revolutions",
                   backend: str = "reduced", step_size: float | None = None,
                   accuracy: float | None = None, max_steps: int | None = None,
                   step_option: str = "--step-size") -> int:
    """Refuse, before any work, a run of `value` `unit` ("revolutions" or "s") of `design`
    (a Linkage, a SliderCrank, None: the paper's) set by the option `option`, when its
    steps (a lower bound: the reduced model steps at most an eighth of a revolution, the
    Exudyn model its fixed step) exceed `max_steps` (default: a run's own limit,
    `settings.DEFAULT_MAX_STEPS`). Also refuses a step
    (`step_size`, the option `step_option`: the Exudyn model's fixed step, or any step
    given with backend "exudyn") longer than a revolution: a run that takes no step in one.
    ValueError naming the option; returns the estimated steps."""
    from ._checks import check_steps
    from .solve.settings import DEFAULT_MAX_STEPS

    period = _period(design)
    seconds = float(value) * period if unit == "revolutions" else float(value)
    what = "a revolution" if unit == "revolutions" else "the run"
    if backend == "exudyn" and step_size is not None:
        span = min(period, seconds)
        if step_size > span:
            raise ValueError(f"{step_option} {step_size:g} s is longer than {what} "
                             f"({span:.4g} s): no step would end within it; give "
                             f"{step_option} below {span:.4g} s")
        step, how = step_size, f"steps of {step_option} {step_size:g} s"
    elif backend == "exudyn" and accuracy is None:
        from .backends.exudyn_linkage import DEFAULT_STEPS_PER_REVOLUTION

        step = period / DEFAULT_STEPS_PER_REVOLUTION
        how = f"{DEFAULT_STEPS_PER_REVOLUTION} steps per revolution"
    elif unit == "revolutions":
        step, how = period / 8, "at least 8 steps per revolution"
    else:
        step, how = period / 8, f"at least 8 steps per {period:.3g} s, the time scale"
    shown = str(value) if isinstance(value, int) else f"{value:g}"
    advice = f"give a smaller {option}"
    if step_size is not None and backend == "exudyn":
        option, advice = f"{option} {shown} with {step_option}", \
            f"give a smaller {option} or a larger {step_option}"
        shown = f"{step_size:g} s"
    return check_steps(f"{option} {shown}: a run of {value:.6g} {unit} ({how})",
                       math.ceil(seconds / step),
                       DEFAULT_MAX_STEPS if max_steps is None else max_steps, advice)


def bound_spans(design, args: argparse.Namespace, revolution: str = "revolutions",
                default: int = 4) -> None:
    """`check_run_size` on the span options of a command, before any work: --duration of a
    free linkage, else --REVOLUTION (`revolution`; `default` when not given) with the run
    options --backend, --step-size and --accuracy, and --settled (a reduced run)."""
    options = dict(backend=getattr(args, "backend", None) or "reduced",
                   step_size=getattr(args, "step_size", None),
                   accuracy=getattr(args, "accuracy", None))
    if design is not None and getattr(design, "drive", True) is None:
        duration, window = getattr(args, "duration", None), getattr(args, "window", None)
        if duration is not None:
            check_run_size(design, "--duration", duration, unit="s", **options)
            if window is not None:
                from .solve.linkage_model import MAX_WINDOWS

                if not window <= duration:
                    raise ValueError(f"--window {window:g} s is longer than --duration "
                                     f"{duration:g} s; give at most --duration")
                if duration / window > MAX_WINDOWS:
                    raise ValueError(f"--window {window:g} s makes more than {MAX_WINDOWS} "
                                     f"windows of --duration {duration:g} s; give at least "
                                     f"{duration / MAX_WINDOWS:.3g} s")
        return
    value = getattr(args, revolution.replace("-", "_"), None)
    check_run_size(design, "--" + revolution, default if value is None else value, **options)
    if getattr(args, "settled", None) is not None:
        check_run_size(design, "--settled", args.settled)


def check_frames(frames: int) -> None:
    """Refuse an animation whose frames (`FRAME_BYTES` each, all held until the file is
    written) exceed the memory limit, naming --frames."""
    from ._checks import check_memory

    check_memory(f"--frames {frames}: the animation's frames need", frames * FRAME_BYTES,
                 None, "give fewer --frames")


def figure_suffixes() -> tuple[str, ...]:
    """File name endings matplotlib can write (.png, .pdf, .svg, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    common = (".png", ".pdf", ".svg")
    others = sorted("." + k for k in FigureCanvasBase.get_supported_filetypes())
    return common + tuple(k for k in others if k not in common)


def parameter_list(text: str) -> tuple[str, ...]:
    """argparse type: comma-separated names (spaces around them allowed), none empty."""
    names = tuple(n.strip() for n in text.split(","))
    if not any(names):
        raise argparse.ArgumentTypeError("needs at least one SliderCrank field, e.g. "
                                         "crank_length,slider_mass; got an empty list")
    if not all(names):
        raise argparse.ArgumentTypeError(f"has an empty name in {text!r} (comma-separated "
                                         f"SliderCrank fields)")
    return names


#: the column headings of the sensitivity table, each defined (printed under the table)
SENSITIVITY_COLUMNS = (
    ("b0", "the parameter's value where the derivative is taken"),
    ("mean |S|", "time average over the last revolution of |S| = |(b0 / F) dF/db| (Eq. 15): "
                 "% change of the force per % change of the parameter (DDM: at rtol 1e-9 "
                 "unless --rtol, on 1440 samples per revolution)"),
    ("max |S|", "its maximum over the last revolution"),
    ("growth/rev", "growth factor of the sensitivity's norm per revolution over the last two "
                   "(about 1: periodic motion, the derivatives mean something)"),
)


def _cmd_sensitivity(args: argparse.Namespace) -> int:
    """sensitivity: the normalised sensitivities of the default output's time series, or
    with --output the peak of that output over the last revolution (a free linkage: the
    last window) and its gradient along --parameters (`objective.peak_gradient`)."""
    from .analysis.sensitivity import DEFAULT_PARAMETERS, summary_sensitivities
    from .units import number

    linkage, mech = design_from_args(args)
    if args.output is not None:
        if args.parameters is None and linkage is not None:
            from .model.design import design_names, slider_crank_of

            if slider_crank_of(linkage) is None:
                raise ValueError(f"--output needs --parameters (comma-separated) of "
                                 f"{design_names(linkage)}")
        if args.backend != "reduced" or args.step_size is not None or args.settled:
            raise ValueError("--output takes the reduced backend from the centred start (no "
                             "--backend, --step-size or --settled)")
    if args.out:
        check_output_dir(args.out, "--out", args.force)
    k, window = free_window(mech, args, "revolutions")
    bound_spans(mech, args)
    if args.output is not None:
        from .analysis.objective import peak_gradient

        span = (f"revolution {k}" if window is None
                else f"time window [{(k - 1) * window:g}, {k * window:g}] s")
        _progress(f"peak of {args.output} over {span} and its gradient by {args.method} ...")
        pg = peak_gradient(mech, args.parameters, revolution=k, window=window,
                           method=args.method, output=args.output, rtol=args.rtol,
                           integrator=args.integrator)
        output = pg.stats["output"]
        # six significant digits (the full values are in --out's peak_gradient.json)
        unit = "N m" if output.startswith("drive_moment") else "N"
        print(f"peak of {output} over {span}: {pg.peak:.6g} {unit} at t = {pg.time:.6g} s "
              f"({args.method})")
        width = max([22] + [len(p) + 1 for p in pg.parameters])
        slope = f"d(peak of {output})/db ({unit} per unit of b)"
        print(f"{'parameter':<{width}} {'b0 (SI)':>12} {slope:>{len(slope) + 2}} "
              f"{'(b0/peak) d/db':>16}")
        for name, b0, g, n in zip(pg.parameters, pg.reference, pg.gradient, pg.normalized):
            print(f"{name:<{width}} {float(b0):>12.6g} {float(g):>{len(slope) + 2}.6g} "
                  f"{n:>16.6g}")
        if pg.message:
            print(f"note: {pg.message}", file=sys.stderr)
        if args.out:
            data = {"output": output, "revolution": pg.revolution,
                    **({"window": window} if window is not None else {}), "peak": pg.peak,
                    "time": pg.time, "method": pg.method, "gradient": pg.as_dict(),
                    "reference": dict(zip(pg.parameters, map(float, pg.reference)))}
            with OutputDir(args.out, "sensitivity") as staged:
                (staged.path / "peak_gradient.json").write_text(json.dumps(data, indent=2))
                staged.commit()
            wrote(args.out / "peak_gradient.json", "the peak and its gradient")
        return 0
    names = args.parameters
    if names is None and linkage is None:
        names = DEFAULT_PARAMETERS
    options = {}
    if args.step_size is not None:
        options["step_size"] = args.step_size
    start = settled_start_of(linkage, args)
    if start is not None:
        options["start"] = start
    if window is None:
        revolutions, span = k, f"{k} revolutions"
    else:
        revolutions, span = None, f"{args.duration:g} s in windows of {window:g} s"
        options.update(duration=args.duration, window=window)
    output = mech.default_output
    _progress(f"sensitivities of {output} by {args.method} ({args.backend}), {span} ...")
    t0 = time.perf_counter()
    sens = summary_sensitivities(mech, names, revolutions, method=args.method,
                                 backend=args.backend, rtol=args.rtol,
                                 integrator=args.integrator, **options)
    print(f"done in {time.perf_counter() - t0:.3g} s", file=sys.stderr)
    print(f"sensitivities of {output} (S = (b0 / F) dF/db, F its magnitude), {span}:")
    width = max([22] + [len(p) + 1 for p in sens.parameters])
    print(f"{'parameter':<{width}} {'b0':>14} {'mean |S|':>10} {'max |S|':>10} "
          f"{'growth/rev':>10}")

    for row in sens.summary():
        unit = PARAMETER_INFO[row["parameter"]][1] if row["parameter"] in PARAMETER_INFO \
            else "-"
        print(f"{row['parameter']:<{width}} {quantity(row['reference'], unit):>14} "
              f"{number(row['mean_abs_normalized']):>10} {number(row['max_abs_normalized']):>10} "
              f"{number(row['growth_per_revolution'], 3):>10}")
    for head, text in SENSITIVITY_COLUMNS:
        print(f"  {head}: {text}")
    if window is not None:
        print(f"  (a free linkage: mean and max over the whole run of {args.duration:g} s, "
              f"growth per window of {window:g} s)")
    if sens.chaotic and window is not None:
        print("NOTE: the sensitivities grow from window to window (a free linkage's motion "
              "is a transient): a derivative is meaningful while runs at other tolerances "
              "agree (compare --rtol values)", file=sys.stderr)
    elif sens.chaotic:
        print("WARNING: the sensitivities grow from revolution to revolution: the motion is "
              "not periodic (chaotic or transient) and these derivatives are not meaningful; "
              "reduce the clearance or the speed.", file=sys.stderr)
    elif sens.periodic is None:
        print(f"NOTE: periodicity {sens.periodicity_note}", file=sys.stderr)
    if args.out:
        from .plotting import SENSITIVITY_FIGURES, plot_sensitivities

        figures = []
        with OutputDir(args.out, "sensitivity") as staged:
            sens.save(staged.path / "sensitivities.npz")
            groups = SENSITIVITY_FIGURES.items() if linkage is None else [
                ("sensitivities", (f"Sensitivities, {linkage.name}", list(sens.parameters)))]
            for stem, (title, group) in groups:
                group = [g for g in group if g in sens.parameters]
                if group:
                    plot_sensitivities(sens, group, title, path=staged.path / f"{stem}.png")
                    figures.append(f"{stem}.png")
            staged.commit()
        what = {"sensitivities.npz": "the sensitivities (load_sensitivities)",
                "sensitivities.trajectory.npz": "the nominal trajectory they belong to"}
        for f in sorted(p.name for p in args.out.iterdir() if p.suffix == ".npz"):
            wrote(args.out / f, what.get(f, "data"))
        for f in figures:
            wrote(args.out / f, "figure")
    return 0


def _case_names() -> list[str]:
    from .model.cases import CASES

    return sorted(CASES)


def _package_version() -> str:
    from mbs_clearance import __version__

    return __version__


def add_linkage_options(p: argparse.ArgumentParser) -> None:
    """--case NAME | --description FILE, and --set NAME=VALUE."""
    source = p.add_mutually_exclusive_group()
    source.add_argument("--case", metavar="NAME", choices=_case_names(),
                        help="a named linkage (default: the paper's slider-crank): "
                             + ", ".join(_case_names()))
    source.add_argument("--description", type=Path, metavar="FILE",
                        help="a linkage described in a .json or .toml file (default: none)")
    p.add_argument("--set", type=case_override, action="append", metavar="NAME=VALUE",
                   help="set a value (repeatable; SI or with a unit, e.g. clearance=0.02mm): "
                        "a field of the paper's slider-crank, a --case override or a "
                        "--description's dotted path (default: none)")


def add_settled_option(p: argparse.ArgumentParser) -> None:
    """--settled N: start a --case / --description from its state after N revolutions."""
    p.add_argument("--settled", type=int_at_least(1), metavar="N",
                   help="--case / --description only: start from the reduced model's state "
                        "after N revolutions (the start's transient settled; the four-bar "
                        "needs about 100), held fixed (default: the centred start)")


def settled_start_of(linkage, args: argparse.Namespace):
    """The `Start` of --settled N for `linkage` (None without it; an error for the paper's
    SliderCrank, which is not a description)."""
    n = getattr(args, "settled", None)
    if n is None:
        return None
    if linkage is None:
        raise ValueError("--settled applies to --case or --description only")
    from .solve.linkage_model import settled_start

    _progress(f"settling {linkage.name!r}: {n} revolutions from the centred start ...")
    return settled_start(linkage, n, rtol=getattr(args, "rtol", None))


def add_run_options(p: argparse.ArgumentParser, methods, integrator_default="dopri5") -> None:
    """--backend, --rtol, --step-size, --integrator."""
    p.add_argument("--backend", choices=BACKEND_NAMES, default="reduced",
                   help="reduced: the compiled reduced model; exudyn: the Exudyn multibody "
                        "model; ideal: ideal joints (closed form)")
    p.add_argument("--rtol", type=positive_float,
                   help="relative tolerance of the reduced backend (default: the model's, "
                        "1e-7)")
    p.add_argument("--step-size", type=positive_time,
                   help="time step in s of the exudyn backend (default: 6000 steps per "
                        "revolution, 2 us at 5000 rpm)")
    p.add_argument("--integrator", choices=methods,
                   help=f"method of the compiled integrator (reduced backend; default "
                        f"{integrator_default})")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand. With `command` given (the one being run), only that
    plugin subcommand is loaded, and none for a built-in one (start-up time)."""
    from .backends.exudyn_linkage import CONTACT_VARIANTS as contact_variants
    from .numerics.integrator import METHODS

    methods = sorted(METHODS)
    parser = Parser(
        prog="mbs-clearance",
        description="Planar linkages with revolute clearance joints: simulate, compare "
                    "models, sensitivities, optimisation, regime maps, validation report.")
    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {_package_version()}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate and print the peaks per revolution (with "
                                       "--out / --plot: the trajectory, a figure)",
                       formatter_class=HelpFormatter,
                       description="Simulate the slider-crank (or a named case, or a linkage "
                                   "described in a file) and print the peaks per revolution; "
                                   "with --out write the trajectory (csv/npz), with --plot a "
                                   "Fig. 3-like figure (nothing is written without them).",
                       epilog="named cases (--case NAME; --set NAME=VALUE changes a value, "
                              "docs/cases.md lists them):\n" + _case_lines())
    add_linkage_options(p)
    p.add_argument("--revolutions", type=int_at_least(1),
                   help="crank revolutions from the start (revolution 1: start-up transient; "
                        "default 4)")
    add_window_options(p, "the peaks are per --window",
                       "the peaks' time windows in s (default: the whole run)")
    add_settled_option(p)
    add_run_options(p, methods)
    p.add_argument("--accuracy", type=positive_float,
                   help="requested relative accuracy of the per-revolution peaks (reduced "
                        "backend: default 1e-5; the run estimates its own error and tightens "
                        "until the estimate is within it; --rtol instead runs once at that "
                        "tolerance. exudyn backend: chooses the step)")
    p.add_argument("--contact", choices=contact_variants,
                   help="clearance-joint variant of the exudyn backend (default symbolic)")
    p.add_argument("--out", type=Path,
                   help="trajectory file, .csv or .npz (default: none written)")
    p.add_argument("--plot", type=Path,
                   help="Fig. 3-like figure file, e.g. simulate.png (paper's slider-crank; "
                        "default: none written)")
    add_force_option(p)
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("sensitivity", help="design sensitivities of the base force (Figs. 4-6)",
                       epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
                              + _case_lines(),
                       description="Sensitivities of the default output (|F12|; a named "
                                   "case: its monitored force) by direct differentiation "
                                   "(reduced model) or finite differences; prints b0 and "
                                   "the mean and max normalized sensitivity (Eq. 15) over "
                                   "the last revolution. "
                                   "With --out, writes sensitivities.npz and Fig. 4-6-like "
                                   "plots into that folder (nothing is written without it).")
    add_linkage_options(p)
    p.add_argument("--parameters", type=parameter_list,
                   help="comma-separated fields: SliderCrank fields (default: the paper's "
                        "eight) or a case's dotted parameter names (default: all but point "
                        "coordinates)")
    p.add_argument("--method", choices=("ddm", "fd"), default="ddm",
                   help="ddm: direct differentiation (reduced model); fd: central finite "
                        "differences (any backend)")
    p.add_argument("--output", metavar="NAME",
                   help="instead of the time series, the peak of this output over the last "
                        "revolution and its gradient along --parameters (case overrides or "
                        "dotted paths): pivot_force:JOINT, shaking_force, drive_moment or "
                        "contact_force:JOINT (default: none)")
    p.add_argument("--revolutions", type=int_at_least(1),
                   help="crank revolutions; the sensitivities are those of the last "
                        "(default 4)")
    add_window_options(p, "the sensitivities' windows; with --output the peak is over the "
                          "last --window")
    add_settled_option(p)
    add_run_options(p, methods, integrator_default="dop853 for ddm, dopri5 for fd")
    p.add_argument("--out", type=Path,
                   help="folder for sensitivities.npz and figures (default: none written)")
    add_force_option(p)
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_sensitivity)

    _add_optimize_parser(sub)
    _add_tolerance_parser(sub)
    _add_map_parser(sub)
    _add_animate_parser(sub)
    _add_lyapunov_parser(sub)
    _add_orbits_parser(sub)
    _add_wear_parser(sub)
    if command not in BUILTIN:
        _add_plugins(sub, command)
    return parser


def _add_optimize_parser(subparsers) -> argparse.ArgumentParser:
    """The ``optimize`` subcommand: GA over the link lengths (paper Section 4, Table 3)."""
    p = subparsers.add_parser(
        "optimize", help="GA optimisation of the link lengths (paper Table 3)",
        description="Minimise the peak base force max |F12| over a crank revolution by "
                    "choosing L2 and L3 with a genetic algorithm (pygad), refine the GA's "
                    "best point locally, print a Table 3-like comparison with the paper and "
                    "write result.json and two figures into --out. A --case or "
                    "--description: the genes (--gene) and the output (--output) are yours.",
        epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
               + _case_lines())
    add_linkage_options(p)
    p.add_argument("--seed", type=int_at_least(0), default=1, help="GA seed (default 1)")
    p.add_argument("--population", type=int_at_least(4), default=20,
                   help="population size (>= 4, default 20)")
    p.add_argument("--generations", type=int_at_least(1), default=30,
                   help="maximum number of generations (default 30)")
    p.add_argument("--saturation", type=int_at_least(0), default=10,
                   help="stop after this many generations without improvement (default 10;"
                        " 0 disables)")
    p.add_argument("--mass-scaling", choices=MASS_SCALING_NAMES, default="fixed",
                   help="fixed: link masses fixed (paper); uniform: crank and coupler masses "
                        "proportional to their lengths")
    p.add_argument("--crank-bounds", type=length_type, nargs=2, metavar=("LO", "HI"),
                   default=(0.04, 0.06),
                   help="bounds of L2 in m (default 0.04 0.06: 40 to 60 mm)")
    p.add_argument("--coupler-bounds", type=length_type, nargs=2, metavar=("LO", "HI"),
                   default=(0.10, 0.14),
                   help="bounds of L3 in m (default 0.10 0.14: 100 to 140 mm)")
    p.add_argument("--revolution", type=int_at_least(1),
                   help="crank revolution whose peak is minimised (default 4)")
    add_window_options(p, "the peak minimised is over its last --window")
    p.add_argument("--gene", type=gene_bounds, action="append", metavar="NAME=LO:HI",
                   help="a gene and its bounds (repeatable; SI or with a unit, e.g. "
                        "crank_length=40mm:60mm): a --case override or a --description's "
                        "dotted path; for the paper's slider-crank its fields (default: the "
                        "--crank-bounds and --coupler-bounds)")
    p.add_argument("--output", metavar="NAME",
                   help="--case / --description: the output whose peak is minimised, "
                        "pivot_force:JOINT, shaking_force, drive_moment or "
                        "contact_force:JOINT (default: the linkage's default output, its "
                        "monitored joint's force or else the shaking force)")
    add_evaluation_options(p, "optimize", accuracy=True)
    add_keep_going_option(p, "designs' runs")
    p.add_argument("--no-refine", action="store_true", help="skip the local refinement")
    p.add_argument("--verbose", action="store_true",
                   help="also print the executor and the refinement's method, objective "
                        "calls and optimality (KKT) check")
    add_force_option(p)
    add_mechanism_options(p)
    leave_to_help_all(p, "seed", "saturation", "mass_scaling", "accuracy", "scheduler",
                      "no_progress", "keep_going", "no_refine", "verbose")
    p.set_defaults(func=_cmd_optimize)
    return p


def format_table3(result, paper_in_model: float, ideal: dict[str, float]) -> str:
    from .studies.optimize import PAPER_TABLE3

    """Markdown table: the paper's Table 3 beside our optimum and the paper's optimum.

    `paper_in_model` is max |F12| of the paper's published optimum in our model, `ideal` the
    ideal-joint (closed form) peaks keyed "original", "optimum", "paper optimum".
    """
    po, pp = PAPER_TABLE3["original"], PAPER_TABLE3["optimum"]
    orig, best = result.original, result.best
    f0 = result.original_peak_force

    def red(f):
        return f"{100.0 * (f0 - f) / f0:.2f}"

    rows = [
        ("original (paper)", po["crank_length"], po["coupler_length"], po["peak_force"], "-",
         "-"),
        ("original (ours)", orig.crank_length, orig.coupler_length, f0, ideal["original"], "-"),
        ("optimum (paper)", pp["crank_length"], pp["coupler_length"], pp["peak_force"], "-",
         f"{PAPER_TABLE3['reduction_percent']:.2f}"),
        ("optimum (ours)", best.crank_length, best.coupler_length, result.best_peak_force,
         ideal["optimum"], red(result.best_peak_force)),
        ("paper's optimum in our model", pp["crank_length"], pp["coupler_length"],
         paper_in_model, ideal["paper optimum"], red(paper_in_model)),
    ]
    lines = ["| design | L2 (cm) | L3 (cm) | max abs(F12) (N) | ideal joints (N) "
             "| reduction (%) |", "|---|---|---|---|---|---|"]
    for name, l2, l3, f, fi, r in rows:
        fi = fi if isinstance(fi, str) else f"{fi:.2f}"
        lines.append(f"| {name} | {l2 * 100:.4f} | {l3 * 100:.4f} | {f:.2f} | {fi} | {r} |")
    return "\n".join(lines)


def _cmd_optimize(args: argparse.Namespace) -> int:
    """optimize: the GA over the genes (the paper's slider-crank: --crank-bounds and
    --coupler-bounds, or --gene), minimising the peak of the default output (or --output)
    over --revolution (a free linkage: its last --window); prints the original and best
    peaks with the output's name (the paper's case also Table 3 beside the paper's) and
    writes result.json and figures into --out."""
    from .plotting import plot_fitness_history
    from .solve.simulate import peak_base_force, simulate
    from .studies.optimize import PAPER_TABLE3, design_mechanism, optimize_link_lengths

    linkage, mech = design_from_args(args)
    paper = linkage is None
    k, window = free_window(mech, args, "revolution")
    args.revolution = k
    bound_spans(mech, args, "revolution")
    if paper and args.output is not None:
        raise ValueError("--output applies to --case or --description (the paper's "
                         "slider-crank minimises |F12|, pivot_force:crank_pivot)")
    if not paper and not args.gene:
        from .model.design import design_names

        raise ValueError(f"--case / --description needs --gene NAME=LO:HI (one or more) of "
                         f"{design_names(linkage)}")
    if not paper and args.mass_scaling != "fixed":
        raise ValueError("--mass-scaling applies to the paper's slider-crank only")
    check_output_dir(args.out, "--out", args.force)
    options = _tolerances(args)
    if args.gene:
        if tuple(args.crank_bounds) != (0.04, 0.06) or tuple(args.coupler_bounds) != (0.10,
                                                                                       0.14):
            raise ValueError("give --gene or --crank-bounds/--coupler-bounds, not both")
        genes = {"genes": _genes(args)}
    else:
        genes = dict(crank_length=tuple(args.crank_bounds),
                     coupler_length=tuple(args.coupler_bounds))
    kind = ({"mass_scaling": args.mass_scaling} if paper else
            {"output": args.output, **({"window": window} if window is not None else {})})
    result = evaluate_on(args, optimize_link_lengths, mech, revolution=k, seed=args.seed,
                         population=args.population, generations=args.generations,
                         saturation=args.saturation or None, refine=not args.no_refine,
                         progress=not args.no_progress, **genes, **kind, **options)
    output = result.settings.get("output", mech.default_output)
    unit = "N m" if output.startswith("drive_moment") else "N"
    span = (f"revolution {k}" if window is None
            else f"time window [{(k - 1) * window:g}, {k * window:g}] s")
    name = "the paper's slider-crank" if paper else f"linkage {linkage.name!r}"
    print(f"{name}: peak of {output} over {span}")
    print(f"original: {result.original_peak_force:.2f} {unit} of {output}")
    print(f"best: {result.best_peak_force:.2f} {unit} of {output} "
          f"({result.reduction_percent:.2f} % lower)")
    for gene, value in result.best_genes.items():
        lo, hi = result.genes[gene]
        print(f"  {gene} = {value:.6g} (bounds {lo:g} .. {hi:g}, SI units)")
    if paper:       # the paper's Table 3 beside ours
        pp = PAPER_TABLE3["optimum"]
        paper_mech = design_mechanism(mech, {"crank_length": pp["crank_length"],
                                             "coupler_length": pp["coupler_length"]},
                                      args.mass_scaling)
        paper_in_model = peak_base_force(paper_mech, k, **options)
        ideal = {key: peak_base_force(m, k, backend="ideal")
                 for key, m in (("original", mech), ("optimum", result.best),
                                ("paper optimum", paper_mech))}
        table = format_table3(result, paper_in_model, ideal)
        print(table)
        print(f"\nmasses: {args.mass_scaling}")
    print(f"seed {result.settings['seed']}; {result.generations_completed} generations, "
          f"{result.n_evaluations} designs simulated in {result.elapsed:.1f} s; GA best "
          f"before refinement {result.ga_best_peak_force:.2f} {unit} of {output}")
    if paper:
        periodic = {True: "periodic", False: "NOT periodic", None: "periodicity not judged"}
        print(f"best design: {periodic[result.best_periodic]}"
              + (f" ({result.best_periodicity_note})" if result.best_periodicity_note
                 else ""))
        if result.best_accuracy_note:
            print(f"note: best design: {result.best_accuracy_note}")
    if args.verbose:
        r = result.refinement
        print(f"evaluated on {result.settings['executor']}; refinement: "
              + (f"{r.get('method')}, {r.get('objective_calls', '?')} objective calls; on "
                 f"bounds: {r.get('on_bounds') or 'none'}; KKT: {r.get('kkt', 'n/a')}"
                 if r else "none"))
    if paper and (mech != type(mech)() or args.mass_scaling != "fixed" or k != 4):
        print("note: the paper's rows refer to its own case (paper mechanism, fixed masses, "
              "4th revolution)")
    files = [("result.json", "the optimisation's result"),
             ("fitness_history.png", "best peak per generation")]
    if paper:
        from .plotting import plot_force_comparison

        designs = {"original": mech, "optimum": result.best, "paper's optimum": paper_mech}
        trajectories = {key: simulate(m, k, **options) for key, m in designs.items()}
        files += [("table3.md", "Table 3 beside the paper's"),
                  ("force_comparison.png", "base force of the three designs")]
    with OutputDir(args.out, "optimize") as staged:
        result.to_json(staged.path / "result.json")
        plot_fitness_history(result, staged.path / "fitness_history.png")
        if paper:
            (staged.path / "table3.md").write_text(table + "\n")
            plot_force_comparison(trajectories, staged.path / "force_comparison.png",
                                  revolution=k)
        staged.commit()
    for file, what in files:
        wrote(args.out / file, what)
    refuse_failed_runs(args, result.n_failed, result.n_evaluations, "designs' runs")
    return 0


def _genes(args: argparse.Namespace) -> dict[str, tuple[float, float]]:
    """{name: (lo, hi)} of the --gene options in SI (a name given twice, a suffix of
    another unit: ValueError)."""
    genes = {}
    unit_of = unit_of_args(args)
    for name, bounds in args.gene or []:
        if name in genes:
            raise ValueError(f"--gene {name} given twice")
        genes[name] = tuple(si_value(f"--gene {name}", b, unit_of(name)) for b in bounds)
    return genes


def _add_tolerance_parser(subparsers) -> argparse.ArgumentParser:
    """The ``tolerance`` subcommand: global sensitivity and exceedance over tolerances."""
    p = subparsers.add_parser(
        "tolerance", help="tolerances and wear: Sobol/Morris/DGSM indices, P(load exceeded)",
        description="Global sensitivity of a run's output to manufacturing tolerances "
                    "(Sobol, Morris, DGSM indices with SALib), its distribution by Monte "
                    "Carlo with P(output > --allowable), and a wear study. Prints the "
                    "indices and writes result.json and summary.txt into --out.",
        epilog="INPUTS: a JSON object {field: {\"uniform\": [lo, hi]} | {\"band\": [nominal, "
               "tol]} | {\"normal\": [mean, sigma]} | {\"fit\": \"H7/g6\", \"diameter\": "
               "0.02}} (field 'radial_clearance' for a fit; SI values), or a SALib parameter "
               "file (lines: NAME LOW HIGH, uniform).\nnamed cases (--case NAME; --set "
               "NAME=VALUE changes a value):\n" + _case_lines())
    p.add_argument("inputs", type=Path,
                   help="input distributions: JSON or a SALib text file (formats: --help-all)")
    add_linkage_options(p)
    p.add_argument("--output", default="peak", metavar="NAME",
                   help="output of a run: peak, rms_drive_moment or max_contact_force; with "
                        "--case / --description also pivot_force:JOINT, shaking_force, "
                        "drive_moment or contact_force:JOINT, its peak (default: peak, of the "
                        "default output: the monitored joint's force or else the shaking "
                        "force)")
    p.add_argument("--revolution", type=int_at_least(1),
                   help="crank revolution of the output (default 4)")
    add_window_options(p, "the output is its peak over the last --window")
    p.add_argument("--sobol", type=int_at_least(0), default=256,
                   help="Sobol base sample N, a power of 2 (0: none; default 256)")
    p.add_argument("--first-order-only", action="store_true",
                   help="no second-order Sobol indices (N (d + 2) runs instead of N (2d + 2))")
    p.add_argument("--morris", type=int_at_least(0), default=0,
                   help="Morris trajectories (0: none)")
    p.add_argument("--dgsm", type=int_at_least(0), default=0,
                   help="DGSM gradient samples (output peak only; 0: none)")
    p.add_argument("--monte-carlo", type=int_at_least(0), default=0,
                   help="Monte Carlo samples of the output distribution (0: none)")
    p.add_argument("--allowable", type=quantity_type(None, 0.0),
                   help="allowable load (> 0, the output's unit): estimate "
                        "P(output > allowable)")
    p.add_argument("--wear", type=length_type, nargs="+", metavar="M",
                   help="radial wear amounts in m added to the clearance (needs --monte-carlo)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed (default 0)")
    add_evaluation_options(p, "tolerance", accuracy=True)
    add_keep_going_option(p, "runs")
    add_force_option(p)
    add_mechanism_options(p)
    leave_to_help_all(p, "first_order_only", "morris", "dgsm", "seed", "accuracy",
                      "scheduler", "no_progress", "keep_going")
    p.set_defaults(func=_cmd_tolerance)
    return p


def _cmd_tolerance(args: argparse.Namespace) -> int:
    from .studies.tolerance import read_inputs, tolerance_study

    linkage, mech = design_from_args(args)
    inputs = read_inputs(args.inputs)
    check_output_dir(args.out, "--out", args.force)
    k, window = free_window(linkage, args, "revolution")
    bound_spans(mech, args, "revolution")
    kw = dict(output=args.output, revolution=k, window=window, sobol=args.sobol,
              second_order=not args.first_order_only, morris=args.morris, dgsm=args.dgsm,
              monte_carlo=args.monte_carlo, allowable=args.allowable, wear=args.wear,
              seed=args.seed, progress=not args.no_progress)
    kw.update(_tolerances(args))
    result = evaluate_on(args, tolerance_study, inputs, mech, **kw)
    text = result.summary()
    print(text)
    with OutputDir(args.out, "tolerance") as staged:
        result.to_json(staged.path / "result.json")
        (staged.path / "summary.txt").write_text(text + "\n")
        staged.commit()
    wrote(args.out / "result.json", "indices and samples")
    wrote(args.out / "summary.txt", "the summary printed above")
    refuse_failed_runs(args, result.counts.get("failed", 0), result.counts.get("runs", 0))
    return 0


def _add_map_parser(subparsers) -> argparse.ArgumentParser:
    """The ``map`` subcommand: regime map / bifurcation diagram."""
    p = subparsers.add_parser(
        "map", help="regime map / bifurcation diagram over one or two fields",
        formatter_class=HelpFormatter,
        description="Run each point of a grid over one or two fields for --revolutions "
                    "crank revolutions, keep the Poincare section of the last --keep, and "
                    "classify the motion (period-k, quasi-periodic, chaotic, ...). Writes "
                    "map.nc (an xarray dataset, netCDF; resumed if it exists with the same "
                    "settings) and figures into --out.",
        epilog="sweeps: NAME=LO:HI:N (linear), NAME=LO:HI:log:N, NAME=V1,V2,...; values SI "
               "or with a unit suffix (crank_speed=500rpm:10000rpm:40, "
               "clearance=1um:0.1mm:log:30). Fields: SliderCrank fields and 'clearance' "
               "(default: the paper's case), a --case's overrides and 'clearance', or a "
               "--description's dotted paths, 'clearance', '<joint>.clearance' and "
               "'crank_speed'.\nnamed cases:\n" + _case_lines())
    add_linkage_options(p)
    p.add_argument("--sweep", action="append", required=True, metavar="SPEC",
                   help="a swept field (once or twice), e.g. clearance=1e-6:1e-3:log:60")
    p.add_argument("--revolutions", type=int_at_least(2), default=100,
                   help="crank revolutions per point (default 100)")
    p.add_argument("--keep", type=int_at_least(1), default=50,
                   help="last revolutions kept as section samples (default 50)")
    p.add_argument("--lyapunov", action="store_true",
                   help="also compute the largest Lyapunov exponent of each point (a "
                        "tangent run instead of the plain one; any --case)")
    p.add_argument("--angle", type=angle_type,
                   help="crank angle of the section in rad (default: the initial angle)")
    p.add_argument("--tol", type=positive_float, default=1e-3,
                   help="recurrence tolerance, fraction of the clearance (default 1e-3)")
    p.add_argument("--max-period", type=int_at_least(1), default=8,
                   help="largest period looked for (default 8)")
    p.add_argument("--write-interval", type=quantity_type("s"), default=5.0, metavar="S",
                   help="write map.nc at most this often while points arrive, in s "
                        "(default 5; and at the end)")
    add_evaluation_options(p, "map")
    add_keep_going_option(p, "points' runs")
    add_force_option(p)
    add_mechanism_options(p)
    leave_to_help_all(p, "tol", "max_period", "scheduler", "no_progress", "keep_going")
    p.set_defaults(func=_cmd_map)
    return p


def _cmd_map(args: argparse.Namespace) -> int:
    from . import plotting
    from .studies.sweep import parse_sweep, regime_map

    if len(args.sweep) > 2:
        raise ValueError(f"--sweep: one or two fields; got {len(args.sweep)}")
    case = args.case
    paper = case in (None, "paper_slider_crank") and args.description is None
    overrides = None
    if paper:
        if getattr(args, "config", None) is None:
            args.case = None            # the paper's case: its SliderCrank fields
        base = mechanism_from_args(args)
    elif case is not None:          # the study rebuilds the case with its overrides
        overrides = _mechanism_changes(args, unit_of_args(args))
        base = None
    else:
        base = linkage_from_args(args)
    if base is not None:      # a case's overrides are checked by the study (its size first)
        check_run_size(base, "--revolutions", args.revolutions)
    unit_of = field_unit(None) if paper else unit_of_args(args)
    sweeps = [parse_sweep(spec, unit_of) for spec in args.sweep]
    kw = dict(case=None if paper or case is None else case, overrides=overrides,
              revolutions=args.revolutions, keep=args.keep, lyapunov=args.lyapunov,
              angle=args.angle, tol=args.tol, max_period=args.max_period, rtol=args.rtol,
              progress=not args.no_progress, write_interval=args.write_interval)
    from .studies.sweep import load_map

    # the folder's rule is every command's; an unfinished run's map.nc is resumed
    check_output_dir(args.out, "--out", args.force, resume={"map.nc": load_map})
    if args.scheduler:
        kw["scheduler"] = args.scheduler
    elif args.workers == 1:
        kw["scheduler"] = "serial"
    else:
        kw["workers"] = args.workers
    with folder_lock(args.out, "--out"):
        path = args.out / "map.nc"
        result = regime_map(base, sweeps, out=path, **kw)
        ds = result.dataset
        print(result.summary())
        for axis in sweeps:
            unit = unit_of(axis.name) or "-"
            spacing = {"log": ", log-spaced", "lin": ", evenly spaced"}.get(axis.spacing, "")
            print(f"{axis.name}: {quantity(min(axis.values), unit)} to "
                  f"{quantity(max(axis.values), unit)}, {len(axis.values)} values{spacing}")
        dims = list(ds["regime"].dims)
        mark = None
        if paper and len(dims) == 2 and set(dims) == {"clearance", "crank_speed"}:
            mark = {"clearance": base.clearance, "crank_speed": base.crank_speed}
        for line in _map_counts(ds, unit_of, args.rtol, mark):
            print(line)
        with OutputDir(args.out, "map") as staged:
            figures = ["bifurcation.png"]
            plotting.plot_bifurcation(ds, staged.path / "bifurcation.png")
            if len(dims) == 2:
                plotting.plot_regime_map(ds, staged.path / "regime_map.png", mark=mark)
                figures.append("regime_map.png")
            shape = ds["regime"].shape
            picks = sorted({0, shape[0] // 2, shape[0] - 1})
            points = [{dims[0]: float(ds[dims[0]].values[i]),
                       **({dims[1]: float(ds[dims[1]].values[0])} if len(dims) == 2 else {})}
                      for i in picks]
            plotting.plot_poincare(ds, points, staged.path / "poincare.png")
            figures.append("poincare.png")
            # the map last: until the folder is in place it stays where a rerun resumes it
            os.replace(path, staged.path / "map.nc")
            try:
                staged.commit()
            except BaseException:
                os.replace(staged.path / "map.nc", path)
                raise
    print(f"{result.computed} points computed, {result.skipped} resumed from {path}",
          file=sys.stderr)
    wrote(path, "regime map dataset")
    for f in figures:
        wrote(args.out / f, "figure")
    refuse_failed_runs(args, int(ds["failed"].sum()), int(ds["failed"].size), "points' runs")
    return 0


def _sci(value: float) -> str:
    """A count with 3 significant digits in exponent form (4.73e8)."""
    mantissa, exponent = f"{value:.2e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def _map_counts(ds, unit_of, rtol: float | None, mark: dict | None) -> list[str]:
    """What a map cost and where its verdicts needed the re-check, read from its dataset:
    the right-hand side evaluations (in all; per point at each end of each field), the
    points re-checked at a tighter rtol (how many, over which values, their regimes), and
    with a marked design the first cell that is not period-1 in the row nearest its
    second field."""
    import numpy as np

    from .analysis.poincare import MIN_RTOL, REGIME_CODES, REGIMES, RESOLVE_FACTOR
    from .solve.settings import DEFAULT_RTOL

    dims = list(ds["regime"].dims)
    computed = (ds["done"].values == 1) & (ds["failed"].values == 0)
    nfev = ds["nfev"].values.astype(float)
    if not computed.any():
        return []

    def at(dim, value):
        return quantity(float(value), unit_of(dim) or "-")

    lines = [f"right-hand side evaluations: {_sci(nfev[computed].sum())} in all, "
             f"{_sci(nfev[computed].min())} to {_sci(nfev[computed].max())} per point"]
    if len(dims) == 2:
        for axis, dim in enumerate(dims):
            for end in (0, -1):
                cells = np.take(nfev, end, axis=axis)[np.take(computed, end, axis=axis)]
                if cells.size:
                    lines.append(f"  at {dim} {at(dim, ds[dim].values[end])}: "
                                 f"{_sci(cells.min())} to {_sci(cells.max())} per point")
    base = DEFAULT_RTOL if rtol is None else rtol
    rechecked = computed & (ds["rtol"].values < base)
    if rechecked.any():
        where = ", ".join(
            f"{dim} {at(dim, ds[dim].values[idx].min())} to {at(dim, ds[dim].values[idx].max())}"
            for dim, idx in zip(dims, (np.unique(i) for i in np.nonzero(rechecked))))
        codes, counts = np.unique(ds["regime"].values[rechecked], return_counts=True)
        regimes = ", ".join(f"{REGIMES[int(c)]}: {n}" for c, n in zip(codes, counts))
        tighter = max(base / RESOLVE_FACTOR, MIN_RTOL)
        lines.append(f"re-checked near the recurrence tolerance at rtol {number(tighter, 3)}: "
                     f"{int(rechecked.sum())} points, {where}; regimes: {regimes}")
    else:
        lines.append("re-checked near the recurrence tolerance: no point")
    if mark is not None:
        first, second = dims
        j = int(np.argmin(np.abs(ds[second].values - mark[second])))
        row = ds["regime"].values                   # (first, second)
        off = np.nonzero(row[:, j] != REGIME_CODES["period_1"])[0]
        text = f"row nearest the marked design's {second} ({at(second, ds[second].values[j])}): "
        if off.size:
            i = int(off[0])
            text += (f"first {first} that is not period-1: {at(first, ds[first].values[i])} "
                     f"({REGIMES[int(row[i, j])]})")
        else:
            text += "period-1 in every cell"
        lines.append(text)
    return lines


def _add_animate_parser(subparsers) -> argparse.ArgumentParser:
    """The ``animate`` subcommand: the mechanism over a revolution, GIF or MP4."""
    p = subparsers.add_parser(
        "animate", help="animation of the mechanism over a revolution (GIF/MP4)",
        description="Simulate the slider-crank (or a named case, or a linkage described in "
                    "a file) and write an animation of one crank revolution into --out "
                    "(GIF; MP4 with --format mp4 where ffmpeg is installed). Any mechanism "
                    "is drawn from its description (the paper's from its case's): bodies "
                    "as polylines through their named points, ground pivots, sliders' "
                    "guides, each clearance "
                    "joint's bearing circle and its journal with the journal's offset "
                    "magnified (the factor is in the title), beside the orbits in units of "
                    "the clearance.",
        epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
               + _case_lines())
    add_linkage_options(p)
    p.add_argument("--revolutions", type=int_at_least(1), default=4,
                   help="crank revolutions simulated")
    p.add_argument("--revolution", type=int_at_least(1),
                   help="the revolution animated (default: the last, --revolutions)")
    p.add_argument("--backend", choices=("exudyn", "reduced"), default="reduced",
                   help="model that computes the motion")
    p.add_argument("--frames", type=int_at_least(2), default=72, help="frames per revolution")
    p.add_argument("--fps", type=int_at_least(1), default=12, help="frames per second")
    p.add_argument("--format", choices=("gif", "mp4"), default="gif",
                   help="file format (mp4 needs ffmpeg)")
    p.add_argument("--magnify", type=positive_float,
                   help="magnification of the journals' offsets in their bearings (default: "
                        "the largest clearance drawn as 40 %% of the drawn bearing radius)")
    p.add_argument("--out", type=Path, default=Path("animate"),
                   help="output folder (default ./animate, named after the command)")
    add_force_option(p)
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_animate)
    return p


def _cmd_animate(args: argparse.Namespace) -> int:
    from .solve.simulate import simulate

    linkage, mech = design_from_args(args)
    bound_spans(mech, args)
    check_frames(args.frames)
    revolution = args.revolutions if args.revolution is None else args.revolution
    if revolution > args.revolutions:
        raise ValueError(f"--revolution must be between 1 and --revolutions "
                         f"({args.revolutions}); got {revolution}")
    from .model.cases import as_linkage
    from .plotting import animate_mechanism, magnification

    # any mechanism is drawn from its description (the paper's from its case's)
    magnify = magnification(as_linkage(mech), args.magnify)
    check_output_dir(args.out, "--out", args.force)
    if args.format == "mp4":
        from matplotlib.animation import FFMpegWriter

        if not FFMpegWriter.isAvailable():
            raise ValueError("--format mp4 needs ffmpeg on the PATH; use --format gif")
    name = linkage.name if linkage is not None else "slider-crank"
    _progress(f"simulating {name!r}, {args.revolutions} revolutions with backend "
              f"{args.backend!r} ...")
    traj = simulate(mech, args.revolutions, backend=args.backend)
    file = f"mechanism.{args.format}"
    with OutputDir(args.out, "animate") as staged:
        animate_mechanism(traj, staged.path / file, revolution=revolution, frames=args.frames,
                          fps=args.fps, magnify=magnify)
        staged.commit()
    what = (f"animation of {name}, revolution {revolution}, journal offsets drawn "
            f"{number(magnify, 3)} times their size")
    wrote(args.out / file, what)
    return 0


#: what the verdict on the largest Lyapunov exponent means (`lyapunov.exponent_verdict`:
#: from its interval; the band |lambda| <= poincare.LYAPUNOV_ZERO counts as zero)
LYAPUNOV_MEANING = {
    "negative": "nearby motions converge: a stable periodic motion, where peaks and "
                "sensitivities mean something",
    "zero": "nearby motions neither converge nor diverge within the resolution: "
            "quasi-periodic or marginal; run longer to decide",
    "positive": "nearby motions diverge: chaotic, only statistics of peaks mean something",
    "undecided": "the interval contains zero: the averaged revolutions do not decide "
                 "between converging and diverging motions; run more revolutions (or a "
                 "longer --transient) to decide",
}


def _add_lyapunov_parser(subparsers) -> argparse.ArgumentParser:
    """The ``lyapunov`` subcommand: the largest Lyapunov exponent of one design."""
    p = subparsers.add_parser(
        "lyapunov", help="largest Lyapunov exponent of a design (periodic or chaotic?)",
        description="Integrate the motion and one tangent vector (the variational equations "
                    "of the generated model, renormalised at the end of each crank "
                    "revolution) and print the largest Lyapunov exponent per revolution and "
                    "in 1/s, averaged over the revolutions after --transient, with what its "
                    "sign means: negative, a stable periodic motion; positive, chaos. A free "
                    "linkage (a --description without a drive): the finite-time exponent "
                    "over --duration seconds, renormalised every --window seconds. "
                    "Nothing is written.",
        epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
               + _case_lines())
    add_linkage_options(p)
    p.add_argument("--revolutions", type=int_at_least(2),
                   help="crank revolutions integrated (default 100)")
    p.add_argument("--transient", type=int_at_least(0),
                   help="first revolutions not averaged (default: half of --revolutions; a "
                        "free linkage: first windows, default 0)")
    add_window_options(p, "the finite-time exponent over it",
                       "the renormalisation interval in s (default: the whole duration)")
    p.add_argument("--rtol", type=positive_float,
                   help="relative tolerance of the state and the tangent (default: the "
                        "model's, 1e-7)")
    p.add_argument("--memory", choices=("reset", "carry"), default="reset",
                   help="the impact-velocity memory's tangent at each renormalisation: reset "
                        "to 0, or carried (docs/regimes.md)")
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_lyapunov)
    return p


def _cmd_lyapunov(args: argparse.Namespace) -> int:
    from .analysis.lyapunov import BLOCKS, lyapunov_exponent
    from .analysis.poincare import LYAPUNOV_ZERO
    from .units import number

    linkage, mech = design_from_args(args)
    span = run_span(mech, args, default=100, what="its exponent runs")
    bound_spans(mech, args)
    if "duration" in span:      # a free linkage: the finite-time exponent over its windows
        _progress(f"finite-time Lyapunov exponent of {linkage.name!r} over "
                  f"{args.duration:g} s ...")
        t0 = time.perf_counter()
        res = lyapunov_exponent(linkage, **span, transient=args.transient, rtol=args.rtol,
                                memory=args.memory)
        print(f"done in {time.perf_counter() - t0:.3g} s", file=sys.stderr)
        n = len(res.log_growth)
        print(f"finite-time largest Lyapunov exponent of {linkage.name} over "
              f"{number(args.duration, 4)} s from its initial state: "
              f"{number(res.per_second, 4)} 1/s ({number(res.per_revolution, 4)} per window "
              f"of {number(res.window, 4)} s; the mean log-growth of windows "
              f"{res.transient + 1}-{n} of {n})")
        return 0
    transient = args.revolutions // 2 if args.transient is None else args.transient
    if transient >= args.revolutions:
        raise ValueError(f"--transient must be between 0 and --revolutions - 1 "
                         f"({args.revolutions - 1}); got {transient}")
    name = linkage.name if linkage is not None else "the paper's slider-crank"
    _progress(f"Lyapunov exponent of {name}: {args.revolutions} revolutions ...")
    t0 = time.perf_counter()
    res = lyapunov_exponent(mech, revolutions=args.revolutions, transient=transient,
                            rtol=args.rtol, memory=args.memory)
    print(f"done in {time.perf_counter() - t0:.3g} s", file=sys.stderr)
    lam = res.per_revolution
    sign = res.verdict
    span = f"the mean over revolutions {transient + 1}-{args.revolutions}"
    if math.isfinite(res.uncertainty):
        print(f"largest Lyapunov exponent of {name}: {number(lam, 4)} +- "
              f"{number(res.uncertainty, 2)} per revolution ({number(res.per_second, 4)} +- "
              f"{number(res.uncertainty / res.window, 2)} 1/s), {span} (+-: batch means of "
              f"{BLOCKS} blocks or the running mean's spread, the larger)")
    else:       # too few revolutions averaged for a spread
        print(f"largest Lyapunov exponent of {name}: {number(lam, 4)} per revolution "
              f"({number(res.per_second, 4)} 1/s), {span}; too few revolutions for an "
              f"uncertainty (average more: --revolutions)")
    print(f"verdict: {sign} (an interval within |lambda| <= {LYAPUNOV_ZERO:g} per revolution "
          f"counts as zero): {LYAPUNOV_MEANING[sign]}")
    trend = "" if sign in ("zero", "undecided") else (
        f": it {'grows' if lam > 0 else 'shrinks'} e-fold every {number(1 / abs(lam), 3)} "
        f"revolutions")
    print(f"  per revolution: the log of the growth of a small perturbation over one crank "
          f"revolution{trend}; 1/s: the same per second")
    if res.regime:
        print(f"regime of revolutions {transient + 1}-{args.revolutions} (the regime map's "
              f"rule): {_regime_line(res)}")
    return 0


def _regime_line(res) -> str:
    """The regime of a Lyapunov run in words, and why it differs from the verdict where it
    does (a period found by recurrence decides over the exponent's sign)."""
    words = res.regime.replace("_", " ")
    if res.period:
        words = f"period-{res.period}" + (
            " (the section repeats every revolution within 1e-3 of the clearance)"
            if res.period == 1 else
            f" (the section repeats every {res.period} revolutions within 1e-3 of the "
            f"clearance; the exponent is averaged over whole periods)")
        if res.verdict != "negative":
            words += (f"; the exponent's verdict is {res.verdict}: a recurrence seen over "
                      f"the averaged revolutions decides the regime, the exponent's sign says "
                      f"whether the repeating motion attracts its neighbours (run longer to "
                      f"settle it)")
    return words


def _coordinate(name: str, value: float) -> str:
    """A coordinate or rate of a section state with its unit (angles in rad, positions in m:
    8 digits resolve a clearance of 0.01 mm on a link of 0.1 m)."""
    rate = name.endswith("_rate")
    unit = "rad" if name.removesuffix("_rate").endswith("angle") else "m"
    return f"{value: .8g} {unit}/s" if rate else f"{value: .8g} {unit}"


def _multiplier(mu: complex) -> str:
    """A Floquet multiplier as modulus and angle (below 1e-9 in modulus: zero to round-off,
    the directions that the contact's damping contracts at once)."""
    size = abs(mu)
    if size < 1e-9:
        return f"|mu| = {size:.1g} (zero to round-off)"
    return f"|mu| = {size:.6g}  angle {math.degrees(cmath.phase(mu)):+.1f} deg"


def _add_orbits_parser(subparsers) -> argparse.ArgumentParser:
    """The ``orbits`` subcommand: a periodic orbit and its stability, or a branch of them."""
    p = subparsers.add_parser(
        "orbits", help="periodic orbit by shooting, its Floquet multipliers; a branch "
                       "over a field with its bifurcations",
        description="Find the periodic orbit of a design by Newton shooting on the state at "
                    "the crank-angle section (the monodromy matrix from the variational "
                    "run), print its section state, Floquet multipliers and stability. With "
                    "--field, --start and --stop, continue it by pseudo-arclength in that "
                    "field, print the folds, period doublings, Neimark-Sacker and grazing "
                    "points found, and with --plot draw the bifurcation diagram (over the "
                    "brute-force samples of a saved regime map with --map).",
        epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
               + _case_lines())
    add_linkage_options(p)
    p.add_argument("--period", type=int_at_least(1), default=1,
                   help="period of the orbit in crank revolutions")
    p.add_argument("--settle", type=int_at_least(0), default=20,
                   help="revolutions of the plain run that gives Newton's first guess")
    p.add_argument("--rtol", type=positive_float,
                   help="relative tolerance of the shooting runs (default 1e-10)")
    p.add_argument("--field", metavar="NAME",
                   help="continue the orbit in this field (a sweep field: clearance, "
                        "crank_speed, a case override or a dotted field; default: none)")
    p.add_argument("--start", type=field_value, metavar="X",
                   help="first value of --field (SI, or with a unit suffix; default: none)")
    p.add_argument("--stop", type=field_value, metavar="X",
                   help="last value of --field (SI, or with a unit suffix; default: none)")
    p.add_argument("--max-points", type=int_at_least(2), default=200,
                   help="most orbits computed along the branch")
    p.add_argument("--max-step", type=positive_float, default=3.0,
                   help="largest continuation step (in clearances of the scaled state and "
                        "of the field's range)")
    p.add_argument("--map", type=Path, metavar="FILE",
                   help="a regime map (map.nc of mbs-clearance map) under the diagram "
                        "(default: none)")
    p.add_argument("--plot", type=Path, metavar="FILE",
                   help="bifurcation diagram of the branch (.png, .pdf, .svg; default: none)")
    add_force_option(p)
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_orbits)
    return p


def _cmd_orbits(args: argparse.Namespace) -> int:
    from .analysis.periodic import continue_orbits, periodic_orbit
    from .plotting import plot_branch

    linkage, mech = design_from_args(args)
    check_run_size(mech, "--settle", args.settle)
    check_run_size(mech, "--period", args.period)
    name = linkage.name if linkage is not None else "the paper's slider-crank"
    branch_args = (args.field, args.start, args.stop)
    if any(a is not None for a in branch_args) and any(a is None for a in branch_args):
        raise ValueError("--field, --start and --stop go together (a branch); give all three "
                         "or none")
    if args.field is None and (args.plot or args.map):
        raise ValueError("--plot and --map draw a branch: give --field, --start and --stop")
    if args.field is not None:
        unit = unit_of_args(args)(args.field)
        args.start = si_value("--start", args.start, unit)
        args.stop = si_value("--stop", args.stop, unit)
    regime = None
    if args.map is not None:
        from .studies.sweep import load_map

        regime = load_map(args.map)
    if args.plot:
        check_output_file(args.plot, "--plot", args.force, suffixes=figure_suffixes())
    t0 = time.perf_counter()
    if args.field is None:
        _progress(f"periodic orbit of {name} ...")
        orbit = periodic_orbit(mech, args.period, settle=args.settle, rtol=args.rtol,
                               trajectory=False)
        print(f"period-{orbit.period} orbit of {name}: {orbit.stability} (Newton: "
              f"{orbit.iterations} iterations, residual {orbit.residual:.2g} of the "
              f"clearance; {time.perf_counter() - t0:.3g} s)")
        from .solve.flows import joints_of

        print("state at the section:")
        coords = orbit.unknowns[:len(orbit.state)]
        for c, v in zip(coords, orbit.state):
            print(f"  {c:<28s} {_coordinate(c, v)}")
        for name, m, v, k in zip(joints_of(orbit.mech), orbit.modes,
                                 orbit.impact_velocities, orbit.onsets):
            print(f"  joint {name!r}: {'contact' if m else 'free flight'} at the section, "
                  f"stored impact velocity {v:.4g} m/s, {int(k)} contact onset(s) per "
                  "period")
        print("Floquet multipliers (largest modulus first; stable when every |mu| < 1):")
        for mu in orbit.multipliers:
            print(f"  {_multiplier(mu)}")
        return 0
    _progress(f"branch of {name} over {args.field} ...")
    branch = continue_orbits(mech, args.field, args.start, args.stop, period=args.period,
                             settle=args.settle, rtol=args.rtol, max_points=args.max_points,
                             step=min(0.1, args.max_step), max_step=args.max_step)
    print(branch.summary())
    print(f"({branch.counters['shooting_runs']} shooting runs, "
          f"{time.perf_counter() - t0:.3g} s)")
    if args.plot:
        plot_branch(branch, args.plot, regime_map=regime)
        wrote(args.plot, "bifurcation diagram")
    return 0


def _add_wear_parser(subparsers) -> argparse.ArgumentParser:
    """The ``wear`` subcommand: a clearance joint's wear life (`studies.wear.wear_life`)."""
    p = subparsers.add_parser(
        "wear", help="wear life of a clearance joint: Archard wear coupled with the dynamics",
        formatter_class=HelpFormatter,
        description="Run the dynamics on the joint's bearing profile, wear it by Archard's law "
                    "(k/H times the contact pressure times the sliding speed, the pressure "
                    "spread by an elastic foundation), extrapolate the wear over an interval "
                    "of cycles chosen by step doubling, update the profile and repeat. "
                    "Prints the peaks, the wear depth and volume over the life and the cycle "
                    "at which a load limit or twice the clearance is reached. Default: the "
                    "case paper_slider_crank_wear.",
        epilog="named cases (--case NAME; --set NAME=VALUE changes a value):\n"
               + _case_lines())
    add_linkage_options(p)
    p.add_argument("--cycles", type=positive_float, default=1e6,
                   help="length of the life in drive revolutions")
    p.add_argument("--joint", metavar="NAME",
                   help="the worn clearance joint (default: the one with a wear_coefficient)")
    p.add_argument("--wear-coefficient", type=positive_float, metavar="K",
                   help="Archard's k/H in m^2/N (default: the joint's wear_coefficient)")
    p.add_argument("--tolerance", type=positive_float, default=0.01,
                   help="profile error accepted per interval, a fraction of the initial "
                        "clearance")
    p.add_argument("--limit", type=quantity_type("N", 0.0), metavar="FORCE",
                   help="a load limit of the monitored output: print the cycle it is first "
                        "reached (e.g. 9kN)")
    p.add_argument("--points", type=int_at_least(8), default=360,
                   help="angles of the profile's grid when the joint starts circular")
    p.add_argument("--settle", type=int_at_least(0), default=3,
                   help="revolutions run on each profile before its wear is recorded")
    p.add_argument("--record", type=int_at_least(1), default=1,
                   help="revolutions whose mean wear is the rate per cycle")
    p.add_argument("--backend", choices=("reduced", "exudyn"), default="reduced",
                   help="the dynamics model")
    p.add_argument("--out", type=Path, metavar="FILE",
                   help="write the life (cycles, profiles, peaks, errors) as .json")
    p.add_argument("--plot", type=Path, metavar="FILE",
                   help="draw the worn profile, the depth against angle and the peaks against "
                        "cycles (.png, .pdf, .svg, ...)")
    add_force_option(p)
    p.set_defaults(func=_cmd_wear)
    return p


def _cmd_wear(args: argparse.Namespace) -> int:
    from .studies.wear import load_wear, wear_life

    if args.case is None and args.description is None:
        args.case = "paper_slider_crank_wear"
    linkage = linkage_from_args(args)
    if args.out:
        check_output_file(args.out, "--out", args.force, suffixes=(".json",), reader=load_wear)
    if args.plot:
        check_output_file(args.plot, "--plot", args.force, suffixes=figure_suffixes())
    name = linkage.case or linkage.name
    _progress(f"wear life of {name}: {number(args.cycles, 6)} cycles ...")
    t0 = time.perf_counter()
    res = wear_life(linkage, args.cycles, joint=args.joint,
                    wear_coefficient=args.wear_coefficient, tolerance=args.tolerance,
                    points=args.points, settle=args.settle, record=args.record,
                    backend=args.backend, progress=sys.stderr.isatty())
    print(f"done in {time.perf_counter() - t0:.3g} s ({res.evaluations} runs of "
          f"{args.settle + args.record} revolutions)", file=sys.stderr)
    print(f"wear of clearance joint {res.joint!r} of {name}: k/H = {res.coefficient:.3g} m^2/N, "
          f"initial clearance {quantity(res.initial_clearance, 'm', 4)}")
    print(f"{'cycles':>12}  {'max depth':>12}  {'volume':>12}  {'peak ' + res.output:>22}  "
          f"{'drive RMS':>12}  regime")
    rows = res.table()
    step = max(1, len(rows) // 12)
    for row in rows[::step] + ([rows[-1]] if (len(rows) - 1) % step else []):
        print(f"{number(row['cycles'], 6):>12}  {number(row['max_depth_um'], 4) + ' um':>12}"
              f"  {number(row['volume_mm3'], 4) + ' mm^3':>12}  {_force(row['peak_N']):>22}  "
              f"{quantity(row['drive_rms_Nm'], 'N m', 4):>12}  {row['regime']}")
    if res.stats.get("stopped"):
        print(f"note: the life {res.stats['stopped']}")
    if res.stats.get("flagged_runs"):
        print(f"note: {res.stats['flagged_runs']} of {res.evaluations} runs were flagged by their "
              "own accuracy check (e.g. a rattling contact: its peaks scatter from run to run)")
    twice = res.cycles_to_clearance(2.0)
    print("twice the initial clearance: " + (
        f"after {number(twice, 4)} cycles" if twice is not None
        else f"not reached in {number(res.cycles[-1], 6)} cycles"))
    if args.limit is not None:
        hit = res.cycles_to_limit(args.limit)
        print(f"load limit {_force(args.limit)}: " + (
            "already exceeded at the start" if hit == 0.0
            else f"first reached after {number(hit, 4)} cycles" if hit is not None
            else f"not reached in {number(res.cycles[-1], 6)} cycles"))
    print(f"error estimate of the final profile: {quantity(res.error_estimate, 'm', 3)} "
          f"({number(100 * res.error_estimate / res.initial_clearance, 3)} % of the initial "
          f"clearance; {len(res.intervals)} intervals, tolerance "
          f"{quantity(res.tolerance, 'm', 3)} each)")
    if args.out:
        write_file(args.out, res.save, "wear life")
    if args.plot:
        from .plotting import plot_wear

        write_file(args.plot, lambda tmp: plot_wear(res, path=tmp), "figure")
    return 0


#: entry-point group through which other packages (this project's `validation`) add
#: subcommands: each entry is a callable register(subparsers), optionally with attributes
#: `help` and `description` for listing it without importing it
#: (mbs_clearance_validation.commands). The library itself never imports `validation`.
PLUGIN_GROUP = "mbs_clearance.commands"


#: the subcommands defined here (the others come from plugins)
BUILTIN = ("simulate", "sensitivity", "optimize", "tolerance", "map", "animate",
           "lyapunov", "orbits", "wear")


def _add_plugins(sub, command: str | None = None) -> None:
    """Add the plugin subcommands: only `command`, fully, if a plugin has that name; else
    all of them for --help and the list of choices, by name and help line alone where the
    plugin offers them (attributes `help` and `description`: its module, with the compiled
    models and scipy, is then not imported)."""
    from importlib.metadata import entry_points

    eps = sorted(entry_points(group=PLUGIN_GROUP), key=lambda e: e.name)
    chosen = [ep for ep in eps if ep.name == command]
    for ep in chosen or eps:
        try:
            register = ep.load()
        except ImportError:  # a plugin whose dependencies are missing is left out
            continue
        if not chosen and hasattr(register, "help"):
            sub.add_parser(ep.name, help=register.help, description=register.description)
        else:
            register(sub)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `mbs-clearance` console script."""
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(command)
    args = parser.parse_args(argv)
    return run_command(f"mbs-clearance {args.command}", args.func, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
