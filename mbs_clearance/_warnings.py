"""Warning categories of the package: users filter them by class.

- `AccuracyWarning`: the result may miss the accuracy the docs state (loose tolerance, a
  grazing contact the integrator cannot resolve, a peak with a rival within the error).
- `PhysicsWarning`: the result is computed as asked but is physically meaningless (penetration
  far beyond the clearance, motion whose periodicity cannot be judged).
- `CacheWarning`: a directory of the compiled-code cache cannot be used (not private, or
  not writable); the next one is tried, down to a private temporary directory. Also: a
  damaged library was dropped (it is built again), or a generated model's source did not
  match its recorded digest (it is generated again, never compiled).
"""

from __future__ import annotations

__all__ = ["MbsClearanceWarning", "AccuracyWarning", "PhysicsWarning", "CacheWarning"]


class MbsClearanceWarning(UserWarning):
    """Base class of the package's warnings."""


class AccuracyWarning(MbsClearanceWarning):
    """The result may miss its stated accuracy; the message says what to change."""


class PhysicsWarning(MbsClearanceWarning):
    """The result is physically meaningless or cannot be judged; the message says why."""


class CacheWarning(MbsClearanceWarning):
    """A directory of the compiled-code cache is unusable (the next one is used, see the
    user guide), or a damaged library or generated model source was dropped and is made
    again."""
