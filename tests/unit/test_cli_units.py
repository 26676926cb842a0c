"""Every command that takes a mechanism takes --case, --description and --set, and every
option that takes a quantity with a unit takes that unit's suffixes (one parser,
`units.parse_quantity`): checked on the parsed arguments, nothing is run."""

import argparse
import json
import math

import pytest

from mbs_clearance.cli import (
    build_parser,
    linkage_from_args,
    mechanism_from_args,
    unit_of_args,
)
from mbs_clearance.model.cases import CASES
from mbs_clearance.units import UNIT_SUFFIXES, parse_quantity

RPM = 2.0 * math.pi / 60.0

#: the commands that take no mechanism: fixed sweeps over their own cases
NO_MECHANISM = {"stress", "bench"}


def _commands():
    from importlib.metadata import entry_points

    from mbs_clearance.cli import BUILTIN, PLUGIN_GROUP

    return list(BUILTIN) + sorted(ep.name for ep in entry_points(group=PLUGIN_GROUP))


def _required(command, tmp_path):
    """The arguments a command requires besides the mechanism (not run: parsed only)."""
    if command == "tolerance":
        inputs = tmp_path / "inputs.json"
        inputs.write_text(json.dumps({"clearance": {"uniform": [1e-5, 2e-5]}}))
        return [str(inputs)]
    if command == "map":
        return ["--sweep", "clearance=1e-5,2e-5"]
    return []


def _sub(command):
    parser = build_parser(command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, sub.choices[command]


def _parse(command, *argv):
    parser, _ = _sub(command)
    return parser.parse_args([command, *argv])


@pytest.mark.parametrize("command", sorted(set(_commands()) - NO_MECHANISM))
def test_every_mechanism_command_takes_case_description_and_set_with_units(command,
                                                                            tmp_path):
    extra = _required(command, tmp_path)
    # a named case and its overrides, with units
    args = _parse(command, *extra, "--case", "four_bar", "--set", "crank_speed=60rpm",
                  "--set", "clearance=0.02mm")
    link = linkage_from_args(args)
    assert link.drive.speed == pytest.approx(60 * RPM, rel=1e-15)
    assert link.clearance_joints[0].clearance == pytest.approx(2e-5, rel=1e-9)
    assert link == CASES["four_bar"](crank_speed=2 * math.pi, clearance=2e-5)
    # a description and its dotted paths, with units
    path = tmp_path / "four_bar.json"
    path.write_text(json.dumps(CASES["four_bar"]().to_dict()))
    args = _parse(command, *extra, "--description", str(path), "--set",
                  "drive.speed=120rpm", "--set", "coupler.mass=500g")
    link = linkage_from_args(args)
    assert link.drive.speed == pytest.approx(4 * math.pi, rel=1e-15)
    assert next(b for b in link.bodies if b.name == "coupler").mass == pytest.approx(0.5)
    # the paper's slider-crank: its fields, with units
    args = _parse(command, *extra, "--set", "crank_speed=2500rpm", "--set",
                  "crank_length=45mm")
    if linkage_from_args(args) is None:
        mech = mechanism_from_args(args)
        assert mech.crank_speed == pytest.approx(2500 * RPM, rel=1e-15)
        assert mech.crank_length == pytest.approx(0.045, rel=1e-15)
    # a suffix of another quantity is refused, naming the value
    args = _parse(command, *extra, "--case", "four_bar", "--set", "crank_speed=2mm")
    with pytest.raises(ValueError, match="--set crank_speed: '2mm' has a unit of m"):
        linkage_from_args(args)


def _quantity_options(sub):
    return [a for a in sub._actions
            if a.option_strings and getattr(a.type, "unit", None) in UNIT_SUFFIXES]


@pytest.mark.parametrize("command", _commands())
def test_every_quantity_option_takes_its_units_suffixes(command, tmp_path):
    """Each option with a unit, given 2<suffix> for each suffix of its unit, holds 2 times
    the suffix's factor in SI."""
    _, sub = _sub(command)
    extra = _required(command, tmp_path)
    options = _quantity_options(sub)
    if command in ("simulate", "map", "compare", "orbits"):
        assert {"clearance", "crank_speed"} <= {a.dest for a in options}
    for action in options:
        for suffix, factor in UNIT_SUFFIXES[action.type.unit].items():
            values = [f"2{suffix}"] * (action.nargs if isinstance(action.nargs, int) else 1)
            args = _parse(command, *extra, action.option_strings[0], *values)
            got = getattr(args, action.dest)
            got = got[0] if isinstance(got, list) else got
            assert got == pytest.approx(2 * factor, rel=1e-15), (action.dest, suffix)


#: words in an option's help that say it takes a dimensional value
UNIT_WORDS = (" in m ", " in m)", " in s ", " in s)", " in s;", " in rad", "(s;", "(s)",
              " in rad/s", " in kg")


@pytest.mark.parametrize("command", _commands())
def test_options_whose_help_names_a_unit_take_units(command):
    """An option whose help says its value is in m, s, rad, kg ... reads it with the
    quantity parser (suffixes accepted), not as a bare float."""
    _, sub = _sub(command)
    for action in sub._actions:
        text = f" {action.help or ''} "
        if action.option_strings and action.type is not None and any(
                w in text for w in UNIT_WORDS) and action.dest not in ("rtol", "max_step"):
            assert hasattr(action.type, "unit"), (command, action.dest)


def test_gene_bounds_sweeps_and_branch_ends_take_units():
    from mbs_clearance.cli import _genes
    from mbs_clearance.studies.sweep import parse_sweep

    args = _parse("optimize", "--case", "four_bar", "--gene", "crank_length=40mm:60mm",
                  "--gene", "crank_speed=50rpm:70rpm")
    genes = _genes(args)
    assert genes["crank_length"] == pytest.approx((0.04, 0.06), rel=1e-15)
    assert genes["crank_speed"] == pytest.approx((50 * RPM, 70 * RPM), rel=1e-15)
    axis = parse_sweep("crank_speed=500rpm:1000rpm:2", unit_of_args(args))
    assert axis.values == pytest.approx((500 * RPM, 1000 * RPM), rel=1e-15)
    with pytest.raises(ValueError, match="sweep clearance: '1rpm' has a unit of rad/s"):
        parse_sweep("clearance=1rpm:2rpm:2", unit_of_args(args))
    assert parse_quantity("90deg", "rad") == pytest.approx(math.pi / 2, rel=1e-15)
    assert parse_quantity("2e-3", "m") == 2e-3
    with pytest.raises(ValueError, match="unknown unit"):
        parse_quantity("3 furlong", "m")
