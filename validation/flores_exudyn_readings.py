"""How Exudyn's window peaks of the translational benchmark's crank pivot force converge
with its step, read raw and smoothed, against the reduced model at rtol 1e-12
(docs/cases/flores_translational_slider_crank.md, "The reduced model against Exudyn"):

    python -m validation.flores_exudyn_readings

Two spans, each in windows of 10 ms, and Exudyn runs at the fixed steps of the step
sequence that a request of its accuracy starts (`exudyn_convergence.first_step`, halved):

- 0.03 s (the `compare` run, accuracy 1e-4): window 3's peak (the bottom corners' first
  impact) at h/2 ... h/32, read raw (`exudyn_linkage.window_peaks` of the force) and
  smoothed (`exudyn_convergence.smoothed`), and each reading's last three steps
  extrapolated (`exudyn_convergence.richardson`);
- 0.02 s (accuracy 1e-5): window 2's peak, the force at the run's last instant, read raw
  and with the one-sided end weights, at h ... h/16; the smoothed readings of h/2, h/4,
  h/8 extrapolated; and the run to accuracy 1e-5 (`simulate(..., accuracy=1e-5)`) against
  the reduced model and its own bar.

Relative differences to the reduced model's peak of the same window; at the 0.03 s runs
also the impact velocity each run registers at the bottom corners' first onset in window
3, against the reduced model's located onsets.
"""

from __future__ import annotations

import numpy as np

#: the contacts whose first impact makes window 3's peak
CORNERS = ("guide.front_bottom", "guide.rear_bottom")


def _readings(linkage, span, step: float):
    """(raw, smoothed) window peaks (N) of one Exudyn run at `step` s over `span`, and the
    impact velocities it registers at each contact's onsets ({contact index: [[t, m/s]]})."""
    from mbs_clearance.backends import exudyn_convergence as xc
    from mbs_clearance.backends import exudyn_linkage as xl

    with xl.capturing_onsets() as capture:
        t, force = xl.monitored_force(linkage, span, xl.make_settings({"step_size": step}))
    raw = xl.window_peaks(t, np.hypot(force[:, 0], force[:, 1]), span.windows)
    return raw, xc._window_peaks(t, force, span), capture.registered


def _reduced_onsets(linkage, duration: float, after: float) -> dict:
    """{contact index: (time in s, impact velocity in m/s)} of each of `CORNERS`' first
    located onset after `after` s in the reduced model at rtol 1e-12 (its contact memory:
    mode and impact velocity, per recorded step)."""
    from mbs_clearance.solve.linkage_model import RunSettings, prepare, solve

    settings, rest = RunSettings.split({"rtol": 1e-12, "duration": duration, "window": 0.01})
    _, ts, _, ms, *_ = solve(prepare(linkage, None, settings, record=True, **rest))
    names = [name for name, _ in linkage.contacts()]
    out = {}
    for name in CORNERS:
        k = names.index(name)
        mode = ms[:, 2 * k]
        on = [i for i in np.flatnonzero((mode[1:] != 0) & (mode[:-1] == 0)) + 1
              if ts[i] > after]
        out[k] = (float(ts[on[0]]), float(ms[on[0], 2 * k + 1]))
    return out


def _extrapolated(values, reference: float) -> str:
    """The last three readings extrapolated: relative value and bar against `reference`."""
    from mbs_clearance.backends.exudyn_convergence import richardson

    value, error, _ = (float(x) for x in richardson(*values[-3:]))
    return (f"{value:.6g} +- {error:.2g} N ({value / reference - 1:+.1e}, bar "
            f"{error / reference:.1e}; {abs(value - reference) / error:.2g} times the bar from "
            "the reduced model)")


def main() -> int:
    from mbs_clearance import simulate
    from mbs_clearance.backends.exudyn_convergence import first_step
    from mbs_clearance.model.cases import flores_translational_slider_crank
    from mbs_clearance.solve.linkage_model import prepare_span

    lk = flores_translational_slider_crank()
    for duration, accuracy, window, halvings in ((0.03, 1e-4, 3, range(1, 6)),
                                                 (0.02, 1e-5, 2, range(0, 5))):
        span = prepare_span(lk, duration=duration, window=0.01)
        reduced = simulate(lk, duration=duration, window=0.01, rtol=1e-12)
        ref = float(reduced.peaks[window - 1])
        inside = (reduced.t >= 0.01 * (window - 1)) & (reduced.t <= 0.01 * window)
        at = reduced.t[inside][np.argmax(np.hypot(*reduced.base_force[inside].T))]
        h0 = first_step(lk, accuracy, {})
        print(f"span {duration:g} s, window {window}: reduced model (rtol 1e-12) {ref:.6g} N "
              f"at {1e3 * at:.2f} ms; steps {1e6 * h0:.3g} us / 2^k (the sequence of accuracy "
              f"{accuracy:g})")
        onsets = _reduced_onsets(lk, duration, 0.02) if duration == 0.03 else {}
        if onsets:
            (ta, _), (tb, _) = onsets.values()
            print("  reduced model's onsets: " + ", ".join(
                f"{name} at {1e3 * onsets[k][0]:.6f} ms" for name, k in zip(CORNERS, onsets))
                + f" ({1e6 * abs(ta - tb):.2f} us apart)")
        raws, smooths = [], []
        for k in halvings:
            raw, smooth, registered = _readings(lk, span, h0 / 2**k)
            raws.append(raw[window - 1])
            smooths.append(smooth[window - 1])
            print(f"  step {1e6 * h0 / 2**k:.3g} us: raw {raws[-1] / ref - 1:+.2e}, smoothed "
                  f"{smooths[-1] / ref - 1:+.2e}", flush=True)
            if onsets:
                first = {i: next(v for t, v in registered[i] if t > 0.02) for i in onsets}
                print(f"  step {1e6 * h0 / 2**k:.3g} us: impact velocity at the onset against "
                      "the reduced model's: " + ", ".join(
                          f"{name.split('.')[1]} {first[i] / onsets[i][1] - 1:+.2e}"
                          for name, i in zip(CORNERS, onsets)))
        if duration == 0.03:
            print(f"  raw, the last three steps extrapolated: {_extrapolated(raws, ref)}")
            print(f"  smoothed, the last three steps extrapolated: {_extrapolated(smooths, ref)}")
            err = np.abs(np.array(smooths) / ref - 1.0)
            print("  smoothed, the error's ratio from one step to the next: "
                  + ", ".join(f"{a / b:.2g}" for a, b in zip(err[:-1], err[1:])))
        else:
            print(f"  smoothed at {1e6 * h0 / 2:.3g}, {1e6 * h0 / 4:.3g} and {1e6 * h0 / 8:.3g} "
                  f"us extrapolated: {_extrapolated(smooths[1:4], ref)}")
            run = simulate(lk, backend="exudyn", accuracy=accuracy, duration=duration,
                           window=0.01)
            peak, bar = float(run.peaks[window - 1]), float(run.stats["peak_errors"][window - 1])
            print(f"  the run to accuracy {accuracy:g}: {peak:.6g} N +- {bar:.2g} N, "
                  f"{peak / ref - 1:+.1e} from the reduced model, {abs(peak - ref) / bar:.2g} "
                  "times its bar")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
