"""The subcommands that the validation package adds to `mbs-clearance`, declared lightly.

Each is an entry point of the group ``mbs_clearance.commands`` (pyproject.toml). Listing the
subcommands (``mbs-clearance --help``) reads only their names and help lines from here; the
module that defines a subcommand's options and body (and imports the compiled models, scipy,
Exudyn ...) is imported only when that subcommand is parsed or run.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Command:
    """One plugin subcommand: its name and help, and where its options and body are.

    Calling it with the CLI's subparsers (the entry-point protocol ``register(subparsers)``)
    imports `module` and adds the full subcommand: options from ``module.<arguments>(parser)``,
    body ``module.<body>(args)``.
    """

    name: str
    help: str
    description: str
    module: str
    arguments: str = "add_arguments"
    body: str = "main"

    def __call__(self, subparsers) -> None:
        mod = importlib.import_module(self.module, __package__)
        p = subparsers.add_parser(self.name, help=self.help, description=self.description)
        getattr(mod, self.arguments)(p)
        p.set_defaults(func=getattr(mod, self.body))

    def run_script(self) -> None:
        """Run the subcommand as ``python -m validation....`` (errors as one line, as in
        the CLI)."""
        from mbs_clearance.cli import Parser, run_command

        mod = importlib.import_module(self.module, __package__)
        parser = Parser(description=self.description)
        getattr(mod, self.arguments)(parser)
        raise SystemExit(run_command(parser.prog, getattr(mod, self.body), parser.parse_args()))


compare = Command(
    "compare", "compare two backends (table + overlay plot)",
    "Simulate one mechanism with two backends, print per-revolution differences and write an "
    "overlay plot.", ".compare", arguments="build_parser", body="run_compare")
stress = Command(
    "stress", "numerical stress sweep (validation)",
    "Numerical stress tests: where do the models break, and do they say so clearly?",
    ".stress")
bench = Command(
    "bench", "work-precision benchmark (validation)",
    "Work-precision: run time against error for every backend and integrator, in one run.",
    ".work_precision")
report = Command(
    "report", "build the validation report (HTML + JSON)",
    "The validation report: the paper reproduced and cross-checked, in one command.",
    ".report")
