"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '361a606ca2cf92a923bb8304dd095a5bd71b503876b93e50173d933d6ac10c11': 'paper_slider_crank',
    '3abf8e5600ddb93e9d00fb87997170bbbef64b2056bf37d7e8dd05e7c03b8801': 'slider_crank_two_clearances',
    'c2f71d84614bf93c0c72e93e5fec9eaeeec625ff1cda26c8dca934d571a99727': 'four_bar',
    '674d15efba505c13a9edad3400663e20a6753fc9651790d213f7f5a21ff7a353': 'paper_slider_crank_friction',
}
