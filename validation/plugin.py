"""Subcommands that the validation package adds to `mbs-clearance` (entry-point plugins)."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def make_register(name: str, help: str, description: str,
                  add_arguments: Callable[[argparse.ArgumentParser], None],
                  main: Callable[[argparse.Namespace], int]):
    """A `register(subparsers)` function for the `mbs_clearance.commands` entry points."""

    def register(subparsers) -> None:
        p = subparsers.add_parser(name, help=help, description=description)
        add_arguments(p)
        p.set_defaults(func=main)

    return register


def run_script(description: str, add_arguments, main, prog: str | None = None) -> None:
    """Run a plugin's main as `python -m validation....` (errors as one line, as in the CLI)."""
    from mbs_clearance.cli import Parser, run_command

    ap = Parser(prog=prog, description=description)
    add_arguments(ap)
    raise SystemExit(run_command(ap.prog, main, ap.parse_args()))
