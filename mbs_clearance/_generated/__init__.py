"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'ad0dd71475fc4aad978c00047af65687bc99d0079056a46b3dacb832826912ee': 'paper_slider_crank',
    '6495cfc4df5233d382740ddd165fb7eb78a64ce96910faa3bb22714cb2fafbe3': 'slider_crank_two_clearances',
    'ff10ffd3b832fe934cf442540d7e7b5f4a436f195427cd65f5a3700ac5ec2494': 'four_bar',
    '6f1ff789d90aa3fdd6f3f5bea54d3a84874d1e7164eca6932b6323a49e966146': 'paper_slider_crank_friction',
}
