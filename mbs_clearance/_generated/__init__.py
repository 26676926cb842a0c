"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'a1e8cd13e316bef71106968d523beb1d77f4d5e5e766ab51e599f7dba6e0e76f': 'paper_slider_crank',
    'f4323ddd58353fc0180d43626916eeaa4ee3396e2725f30ab71e485a409f1305': 'slider_crank_two_clearances',
    'b6b1bef0dbbb1aa563cb9d2b0b1fc81ddc96a5ded3b725969c6ba767c01b284d': 'four_bar',
    '7e0d3a1d0806c8f6c988696b700db5b35e60afa1cf789224ea9eac2153475fff': 'paper_slider_crank_friction',
}
