"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'b40d1b49ad29316a6f745de43d1ba1574fb08751de8f6e45d154e16eb116a24e': 'paper_slider_crank',
    'dab484a58b76f6198c50477626805a04a4d14c8e773af13975f28880ce446a5a': 'slider_crank_two_clearances',
    'db5d500bb29c23329a691a04583002c9430d82598ebf981c3be250e40160c01d': 'four_bar',
    'c3a4b3863f6e2d5e1406d5ae22caf35325f44e6c1abc7cbb23763845c7d00f7a': 'paper_slider_crank_friction',
}
