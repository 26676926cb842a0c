"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '63d0453923b6e1090ac1ce684ca045555e76520af79e926d36535fdde82eb837': 'paper_slider_crank',
    '5aaa9c683a2875d551a2ef8007bd64f8663f44a62c34dc70141f0ffac72574b1': 'slider_crank_two_clearances',
    '04c3e06cd35629611296f33c31266ef2df60a7e3e7a393116d6558b03a1e928f': 'four_bar',
    '9d95b835133c9d45896a53b318e757d0e9b1abe140cd8fae4213261efc6e8d47': 'paper_slider_crank_friction',
}
