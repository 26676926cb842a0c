"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'bd148cfffde37e586fe8dcaa0ff6d2a21abaab7cd2165f3e8647a4eb7d518d33': 'paper_slider_crank',
    '50750f5c627b1be7341f578cc09f22a2849dd26ed3f0afb3561d771c28c28023': 'slider_crank_two_clearances',
    '3705872e7f52aea3561dfea3e3151295f79107da25de15de9e9335b389e5a7fe': 'four_bar',
    'fea3304769e7d1e570918d94dd93438b5246f162ae251f8b32d6970202a84dfc': 'paper_slider_crank_friction',
}
