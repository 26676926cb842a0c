"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'a11773ec455b798fd4d1e067a0b8e3c33ddb21a9d927972849ee1b1acb3ce433': 'paper_slider_crank',
    'cbfa31ef44fa88ac74d7973f77ea698e519c89f71e71d910462133a9e3b7796f': 'slider_crank_two_clearances',
    'ff690bf22fb42717f3f472895f88a90b719aadd9b6e07d2f3f81783a0dfefbac': 'four_bar',
}
