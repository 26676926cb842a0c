"""Checked-in generated model modules of the named cases (written by
tools/generate_models.py; do not edit). MODULES maps a structure digest to a module name."""

MODULES: dict[str, str] = {
    'b283f50383a4af24c4fedc79f835d340b55126376dc25b94fec6bb27dfea507a': 'paper_slider_crank',
    'eb0a97fbb57575274e10fe5d7d9e7d4af0b2e67ad2e8b8a5d6ae5c0b81b69717': 'slider_crank_two_clearances',
    '01a0dafa28b9d982a4b7178c274eaf9024fdcc37de9988865ef498f7acf46f5c': 'four_bar',
    '346e2de397ee492677ef30c1c6206071e9e5296fd7446b6e74fe34c1171500c1': 'paper_slider_crank_friction',
}
