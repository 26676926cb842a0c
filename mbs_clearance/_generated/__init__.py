"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'c7770ccb9a0b0b7b6a5918a3ae4a30f2ca11d9c7e76be893a1ebbd913a7ebca1': 'paper_slider_crank',
    '65e401805bf3702ae3e7b19ccc9f047c6c1e7833795c7ce65cd2a21b74aa3572': 'slider_crank_two_clearances',
    '3975ee4709a1c92a200d57182e9a3d866013f1f81cb7647eeb6ca5447bb8693b': 'four_bar',
    '635ad707e4b930853b5ae01880948b736c05a0fd948b9e380a0f5ee2d7852381': 'paper_slider_crank_friction',
}
