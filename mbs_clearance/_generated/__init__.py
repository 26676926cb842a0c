"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'deff278815934bf12621b2e88b4e1f7501c2d1534848eb0fdffd16acdd332d93': 'paper_slider_crank',
}
