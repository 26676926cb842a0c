"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '1ebba2c9fe3079d0da0e795e787a4f875de9f1c726085904bb782678ccd83453': 'paper_slider_crank',
    'dd3c934a2d49e128e440a6affa2f58a4d8ba89e717116ce90987224795928fca': 'slider_crank_two_clearances',
    '397b5eb247db4e1455a05273ea7026fae732a6396d5f977cc873ef0a4cc37411': 'four_bar',
    'd1fd701e717e2014bd9279feb2bae3fcedfde8492ab9c510599811910066a840': 'paper_slider_crank_friction',
}
