"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '8402582e3c21343fd46687d8c7e407a46e8d0974a5c0499a2a6f19803e85c247': 'paper_slider_crank',
    '9812cf3b4fe848b7c684ca9fddff96c5538e5b85658b2df761e3b71360df7248': 'slider_crank_two_clearances',
    '962877e8e4fa9e80844482a6f932cf23ecbee9082f552bbebc07750a48241c34': 'four_bar',
    'ad068f62d0d4093f27b0ae2b53f96264d79dec35d9a1ffbc6a2c7a8afe0b0071': 'paper_slider_crank_friction',
}
