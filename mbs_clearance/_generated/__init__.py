"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'c60137b1cc164321a985c434918d1ce6ce833f31d96cf96c00fd21c5a7fac147': 'paper_slider_crank',
    'b9b7fc6acccf60e754f91b5ab553149613b3151901485ce5074d85b89ac75354': 'slider_crank_two_clearances',
    '6844ac760d8e9184987e3adb8851dc14e2d787123f13c7866867c8143f65d6cb': 'four_bar',
    'ab0792f841445fa9167591a857ec221ff090159a2fa6ef1d9f8645fd6e8b819c': 'paper_slider_crank_friction',
}
