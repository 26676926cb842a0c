"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '544a1d5567fac8699ea3c5a96b423e2b26372d82ce0ffcc14d868ee28399bec5': 'paper_slider_crank',
    'b004010c3b11db56879b9e24b96187730064ba9cfeeb298e7927d549c2f92915': 'slider_crank_two_clearances',
    '666bfee01de24026d053a8f0319e4d0360d3b8869b3f73b4b332d5bdc29cab43': 'four_bar',
    '5f5e05581f3e4a0604332e4383e76e7f15949a19a5d9f3489b81b8bc70ca97e8': 'paper_slider_crank_friction',
}
