"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '935b483698bc59463454d08692818dcb106a89ed3d011afce00602d7cd8ae314': 'paper_slider_crank',
    '361bc1d154b97690e6308245465fa1081a6616d39a1fee551228e27187696d95': 'slider_crank_two_clearances',
    '175b0ae167e04974220a758ee51443df11b23b17670751fab8a73218997e0c96': 'four_bar',
    '09dabf99739beb7f6bc6b1841ad22e055114453b4207e3479d8f7bc57f2f0086': 'paper_slider_crank_friction',
}
