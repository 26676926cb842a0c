"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '811aaa063d9be7576c48ffb376ffe20c2bfd5780c4b186f2753e14dff11acbe4': 'paper_slider_crank',
    'b7dbc99113b46f74005035655a8ae114a47d50fd3049a3ceadba8be31ce0c6c6': 'slider_crank_two_clearances',
    '9bd8b05020b57494f535322ed528cbdacaf1e3c953cb27a5deffc4999a6accf1': 'four_bar',
    '4c46a44d05d7abb1aed6b7e41cf94d9b31cf85619a01509fdf43a2b0db069429': 'paper_slider_crank_friction',
}
