"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'a11773ec455b798fd4d1e067a0b8e3c33ddb21a9d927972849ee1b1acb3ce433': 'paper_slider_crank',
}
