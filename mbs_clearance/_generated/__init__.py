"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '3f7d55226b938a3fb5a40dd52d9e306b8954707276f4497eeab2d9dd0a9c8215': 'paper_slider_crank',
    'c3ba4dbde5821463ab2b856d627e24d852026d948b6b2e0499600f45a02611ec': 'slider_crank_two_clearances',
    'd6cf89a4be4d4da3a0fcb0e57104f74c1f18d9fb50d5fba72aa16c020cdae5b4': 'four_bar',
    'd12f7193fceb8a37082857d1c19f95f4f1b9f30253e035acc7ec2b126055ab79': 'paper_slider_crank_friction',
    'c7770ccb9a0b0b7b6a5918a3ae4a30f2ca11d9c7e76be893a1ebbd913a7ebca1': 'paper_slider_crank',
    '65e401805bf3702ae3e7b19ccc9f047c6c1e7833795c7ce65cd2a21b74aa3572': 'slider_crank_two_clearances',
    '3975ee4709a1c92a200d57182e9a3d866013f1f81cb7647eeb6ca5447bb8693b': 'four_bar',
    '635ad707e4b930853b5ae01880948b736c05a0fd948b9e380a0f5ee2d7852381': 'paper_slider_crank_friction',
}
