"""Optimise the link lengths of the paper's slider-crank with the genetic algorithm.

`optimize_link_lengths` minimises the peak base force over the 4th revolution over the crank
and coupler lengths (the paper's Eq. 18: L2 in [4, 6] cm, L3 in [10, 14] cm); it takes a
`SliderCrank`, so this example optimises the paper's mechanism (a four-bar's lengths cannot
be optimised with it). The population and generations here are small so that the script
runs in seconds; `mbs-clearance optimize --seed 1` runs the default 20 x 30.

    python examples/optimize_link_lengths.py
"""

from mbs_clearance import SliderCrank, optimize_link_lengths

opt = optimize_link_lengths(SliderCrank(), seed=1, population=8, generations=5,
                            progress=False)
best = opt.best
print(f"original design: {opt.original_peak_force:.1f} N")
print(f"best design: L2 = {best.crank_length * 100:.3f} cm, "
      f"L3 = {best.coupler_length * 100:.3f} cm, {opt.best_peak_force:.1f} N "
      f"({opt.reduction_percent:.2f} % less)")
