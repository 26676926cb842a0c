"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '20d756729fdc75a97bebce95786e7f1083e43a0cd17a38fd8a2e0bef49a9b996': 'paper_slider_crank',
    'af065b1fca31ad3cf70b5e9ae071d517bd6ff30ac435b69efea2033acf8f773e': 'slider_crank_two_clearances',
    '9c1ce365c0fbd7f90ec791b7217469d12625bff10bd520f93f00009c6a8af346': 'four_bar',
    '4bff47262a665e476543d6714a81b7b93d3fff9a5f8336a3b007e670ce8a500a': 'paper_slider_crank_friction',
}
