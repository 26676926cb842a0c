"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '28827036d8ba57343936826dafb04d0e620fdab4a14f5bb9a6552e15b0e02ef9': 'paper_slider_crank',
    '55699602ef89980ddb565b3ce032d3b0d43b611d882372fb1519483a3eb54793': 'slider_crank_two_clearances',
    '6dc0c8c3865905b2b6ab15ccddb221ec3c39b6840073c168f318aff072ff08fe': 'four_bar',
    'a678249d93521f7121e6c2f9261b87328fa0fb219c777b5b32222d712cf2b469': 'paper_slider_crank_friction',
}
