"""A small regime map: periodic or not, over clearance and crank speed.

Each point is simulated for 100 crank revolutions, sampled once per revolution over the
last 50 (a Poincare section) and classified: period-1, period-k, aperiodic (no recurrence;
`lyapunov=True` tells quasi-periodic from chaotic), ... The grid here is 2 x 2 so that it
runs in seconds; `mbs-clearance map` makes the full maps (docs: Regimes).

    python examples/regime_map.py
"""

from mbs_clearance import SliderCrank, regime_map

res = regime_map(SliderCrank(), ["clearance=1e-5,5e-4", "crank_speed=3000rpm,5000rpm"],
                 revolutions=100, keep=50, progress=False)
print(res.summary())
ds = res.dataset
for c in ds["clearance"].values:
    for w in ds["crank_speed"].values:
        point = ds.sel(clearance=c, crank_speed=w)
        code = int(point["regime"])
        meaning = ds["regime"].attrs["flag_meanings"].split()[code]
        print(f"clearance {c * 1e3:.3f} mm, {w * 30 / 3.141592653589793:.0f} rpm: {meaning}, "
              f"mean peak {float(point['peak_mean']):.0f} N")
