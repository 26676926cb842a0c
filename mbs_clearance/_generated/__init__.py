"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '160dbb658a1648461e4a4e2cfa5f76cfdc4e345049eaa8ce6bb406a5cda9f137': 'paper_slider_crank',
    'a0464d16b9c1006cc4d7ee11a91d6d5aa57a3fbfaa57ec965908978211292d29': 'slider_crank_two_clearances',
    '28a89f57fc5dba4a960243750a5a62120116b9a1ae02a87bd5639d843a6d562c': 'four_bar',
    'e1cdeadfd8630da6f433ecc834145a8f878837e42eb016872a3f3bdb60c712c2': 'paper_slider_crank_friction',
}
