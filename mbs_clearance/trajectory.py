"""`Trajectory`: the one result type of every backend, with derived outputs and save/load."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .mechanism import SliderCrank

__all__ = ["Trajectory", "load_trajectory"]

#: name -> (unit, number of columns); the time series every backend fills
SERIES: dict[str, tuple[str, int]] = {
    "t": ("s", 1),
    "base_force": ("N", 2),
    "crank_moment": ("N m", 1),
    "contact_force": ("N", 1),
    "penetration": ("m", 1),
    "eccentricity": ("m", 2),
    "slider_position": ("m", 1),
    "slider_velocity": ("m/s", 1),
    "slider_acceleration": ("m/s^2", 1),
    "coupler_angle": ("rad", 1),
    "coupler_rate": ("rad/s", 1),
    "contact_phase": ("-", 1),
    "crank_work": ("J", 1),
}


@dataclass(frozen=True)
class Trajectory:
    """Time series of one simulation of a `SliderCrank`.

    Attributes
    ----------
    t : (n,) s
    base_force : (n, 2) N, force exerted on the ground by the crank at the pivot (F12)
    crank_moment : (n,) N m, driving moment that keeps the crank speed constant (Eq. 8)
    contact_force : (n,) N, normal force in the clearance joint
    penetration : (n,) m, delta = |eccentricity| - clearance (negative in free flight)
    eccentricity : (n, 2) m, journal centre relative to bearing centre
    slider_position, slider_velocity, slider_acceleration : (n,) m, m/s, m/s^2
    coupler_angle, coupler_rate : (n,) rad, rad/s
    contact_phase : (n,) int, 1 while in contact, 0 in free flight
    crank_work : (n,) J, work done by the crank drive since t = 0 (NaN-free; zeros if the
        backend does not integrate it)
    mechanism : the simulated SliderCrank
    backend : name of the backend
    stats : counters of the solver (nfev, naccept, nreject, nevent, ...) and settings
    peaks : (revolutions,) N, max |F12| per revolution refined between samples, or None
    """

    t: np.ndarray
    base_force: np.ndarray
    crank_moment: np.ndarray
    contact_force: np.ndarray
    penetration: np.ndarray
    eccentricity: np.ndarray
    slider_position: np.ndarray
    slider_velocity: np.ndarray
    slider_acceleration: np.ndarray
    coupler_angle: np.ndarray
    coupler_rate: np.ndarray
    contact_phase: np.ndarray
    crank_work: np.ndarray
    mechanism: SliderCrank
    backend: str
    stats: dict[str, Any] = field(default_factory=dict)
    peaks: np.ndarray | None = None

    # ------------------------------------------------------------------ derived outputs
    @property
    def base_force_magnitude(self) -> np.ndarray:
        """|F12| in N, shape (n,)."""
        return np.hypot(self.base_force[:, 0], self.base_force[:, 1])

    @property
    def crank_angle(self) -> np.ndarray:
        """theta2 = omega2 t + theta20 in rad, shape (n,)."""
        m = self.mechanism
        return m.crank_speed * self.t + m.initial_crank_angle

    @property
    def revolutions(self) -> int:
        """Number of full crank revolutions covered."""
        return int(np.floor(self.t[-1] / self.mechanism.period + 1e-9))

    def revolution_window(self, revolution: int) -> tuple[float, float]:
        """Time interval [t_a, t_b] of crank revolution `revolution` (1-based) in s."""
        if not isinstance(revolution, (int, np.integer)) or revolution < 1:
            raise ValueError(f"revolution must be an integer >= 1; got {revolution!r}")
        if revolution > self.revolutions:
            raise ValueError(
                f"revolution must be between 1 and {self.revolutions} (the trajectory covers"
                f" {self.revolutions} full revolutions); got {revolution}"
            )
        period = self.mechanism.period
        return (revolution - 1) * period, revolution * period

    def revolution_mask(self, revolution: int) -> np.ndarray:
        """Boolean mask of the samples inside revolution `revolution` (1-based)."""
        t_a, t_b = self.revolution_window(revolution)
        tol = 1e-12 * max(1.0, t_b)
        return (self.t >= t_a - tol) & (self.t <= t_b + tol)

    def max_base_force(self, revolution: int = 4) -> float:
        """Maximum of |F12| in N over revolution `revolution` (1-based).

        Uses the peak refined between samples where the backend provides it (reduced model),
        otherwise the maximum over the samples.
        """
        mask = self.revolution_mask(revolution)
        if self.peaks is not None and len(self.peaks) >= revolution:
            return float(self.peaks[revolution - 1])
        return float(self.base_force_magnitude[mask].max())

    # ------------------------------------------------------------------ save / load
    def save(self, path: str | Path) -> Path:
        """Write to ``.npz`` (all data) or ``.csv`` (series, metadata in a comment line)."""
        path = Path(path)
        meta = self._meta()
        if path.suffix == ".npz":
            arrays = {name: getattr(self, name) for name in SERIES}
            if self.peaks is not None:
                arrays["peaks"] = self.peaks
            np.savez_compressed(path, meta=np.array(json.dumps(meta)), **arrays)
        elif path.suffix == ".csv":
            columns, header = self._columns()
            np.savetxt(path, columns, delimiter=",", header="# " + json.dumps(meta) + "\n"
                       + ",".join(header), comments="", fmt="%.17g")
        else:
            raise ValueError(f"trajectory file must end in .npz or .csv; got {str(path)!r}")
        return path

    def _meta(self) -> dict[str, Any]:
        stats = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in self.stats.items()}
        meta = {"mechanism": self.mechanism.to_dict(), "backend": self.backend, "stats": stats}
        if self.peaks is not None:
            meta["peaks"] = [float(p) for p in self.peaks]
        return meta

    def _columns(self) -> tuple[np.ndarray, list[str]]:
        cols, header = [], []
        for name, (unit, ncol) in SERIES.items():
            data = np.asarray(getattr(self, name), dtype=float)
            if ncol == 1:
                cols.append(data)
                header.append(f"{name}[{unit}]")
            else:
                for j, axis in enumerate("xy"):
                    cols.append(data[:, j])
                    header.append(f"{name}_{axis}[{unit}]")
        return np.column_stack(cols), header


def load_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory written by `Trajectory.save` (``.npz`` or ``.csv``)."""
    path = Path(path)
    try:
        if path.suffix == ".npz":
            with np.load(path) as data:
                meta = json.loads(str(data["meta"]))
                series = {name: data[name] for name in SERIES}
        elif path.suffix == ".csv":
            with open(path) as fh:
                meta = json.loads(fh.readline()[1:].strip())
                header = fh.readline().strip().split(",")
            table = np.loadtxt(path, delimiter=",", skiprows=2, ndmin=2)
            series = {}
            for name, (_, ncol) in SERIES.items():
                if ncol == 1:
                    series[name] = table[:, header.index(f"{name}[{SERIES[name][0]}]")]
                else:
                    idx = [header.index(f"{name}_{a}[{SERIES[name][0]}]") for a in "xy"]
                    series[name] = table[:, idx]
        else:
            raise ValueError(f"trajectory file must end in .npz or .csv; got {str(path)!r}")
    except (OSError, KeyError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read trajectory file {str(path)!r}: {exc}") from exc
    series["contact_phase"] = series["contact_phase"].astype(np.int8)
    peaks = meta.get("peaks")
    return Trajectory(
        **series,
        mechanism=SliderCrank.from_dict(meta["mechanism"]),
        backend=meta["backend"],
        stats=meta.get("stats", {}),
        peaks=None if peaks is None else np.asarray(peaks, dtype=float),
    )


Trajectory.load = staticmethod(load_trajectory)  # type: ignore[attr-defined]
