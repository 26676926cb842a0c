"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    '4b0e8a9fe181e01ddf002419b02b6b550400f91b0c445b28450ba4f33177cf82': 'paper_slider_crank',
    '908b10684380b35946136c54a45d502d743a342520f6b9f27997d0db9dd0d382': 'slider_crank_two_clearances',
    '96e93d6f4eef80a13fc8d40db7cff986e330ec152536d87c9bbcc91b83e5b0e1': 'four_bar',
    '1c397ac8b201dcc88242c06ecb237f27fa619a364bdadf6316824d6f4bc42d87': 'paper_slider_crank_friction',
}
