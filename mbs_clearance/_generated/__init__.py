"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '655d360b0d155b98e584fb02c5eb358ad46569360a33052731e9f722566a511c': 'paper_slider_crank',
    '0e2f09c436bb8da999a63b1aa6e8e36f3560857b146cd9f1073afdfbeac33cfa': 'slider_crank_two_clearances',
    'aa6818650be699481b862edb4684886755cdbf1e9825e39c9b462e2fa2b8a229': 'four_bar',
}
