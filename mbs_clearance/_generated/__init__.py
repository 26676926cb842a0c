"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'ad763907a0448533472d08fe2aa6e93c764df2229616296c1d958bccb64c4576': 'paper_slider_crank',
    '0e93fb021bf182c61dc35f3fdadcf700db6c1ff79677e37117b7313af4d1e624': 'slider_crank_two_clearances',
    '432870fa3d09cb6113e91d47664b6413a23478c43611b90cdd38a43512aa85a0': 'four_bar',
    '70e9fd4316dca6fc4c1f23e4120f53e610fbf9b367c0b20a9e193f71f886ec92': 'paper_slider_crank_friction',
}
