"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'cfdd5260a9180ad68192d888e8e80a8bdc78e54152e554a4f07b6e4ade115a3d': 'paper_slider_crank',
    '8b6b6b57578ff57ac131e7439baefdb1b276ba65672034674aca2a2b31adccbf': 'slider_crank_two_clearances',
    '5f78541c27e157d02c9d765a18d2c834871ac87257eed43869ae614eb374fa8c': 'four_bar',
    '05db4800d3445cffb1a5642a5eee32896b7d8ba3333c15eae08065435ac4f0e2': 'paper_slider_crank_friction',
}
