"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'a3972eca799fc6233dd7403dedff8ca7b9a78259e2ce4180af154b92f2063177': 'paper_slider_crank',
    '3f94a1ee4d486e8e13c08ed3f9d963cf4ee1833ab8e523d06491fb0079206b57': 'slider_crank_two_clearances',
    'ed28445add05b1c372fba6c0f37b003df97b01bd04b561b94ed5369085fbead7': 'four_bar',
    '509f6398559de30bde59a61251183b6bf4435d8c91a6f4038e39dd80bbd9080a': 'paper_slider_crank_friction',
}
