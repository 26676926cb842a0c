"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'a92d02bde0350143848fcb9f252a0043cda35fd8ad2a39038b43e68ddaa6ca89': 'paper_slider_crank',
    '57f84236999007e4e27db575983ac3035551c8201c3ce27b231122f2f3a95d46': 'slider_crank_two_clearances',
    '71f166249c728efdb7ac4db64f75a5960d52fdaa5e982edc21247f9bd5afc5d8': 'four_bar',
    'e7e5f682694d9749effc7a11bcf051028673fe3d83ee860bac9afa16f70f750a': 'paper_slider_crank_friction',
}
