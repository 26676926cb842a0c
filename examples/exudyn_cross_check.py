"""Cross-check the reduced model against the Exudyn model of the same mechanism.

Exudyn builds the paper's slider-crank from rigid bodies and joints with the contact law as
a user force and computes the base force from its own joint reaction; the reduced model
integrates the paper's equations. The two are compared over the 4th revolution.

    python examples/exudyn_cross_check.py
"""

import numpy as np

from mbs_clearance import SliderCrank, simulate

mech = SliderCrank()
reduced = simulate(mech, revolutions=4)
exudyn = simulate(mech, revolutions=4, backend="exudyn")  # default step 2e-6 s

p_red, p_exu = reduced.max_base_force(4), exudyn.max_base_force(4)
print(f"max |F12|, revolution 4: reduced {p_red:.1f} N, Exudyn {p_exu:.1f} N "
      f"({100 * (p_exu / p_red - 1):+.3f} %)")

# RMS difference of |F12| over revolution 4 on Exudyn's time grid
m = exudyn.revolution_mask(4)
f_red = np.interp(exudyn.t[m], reduced.t, reduced.base_force_magnitude)
rms = np.sqrt(np.mean((exudyn.base_force_magnitude[m] - f_red) ** 2))
print(f"RMS difference of |F12| over revolution 4: {100 * rms / p_red:.2f} % of the peak")
