"""Warning categories of the package: users filter them by class.

- `AccuracyWarning`: the result may miss the accuracy the docs state (loose tolerance, a
  grazing contact the integrator cannot resolve, a peak with a rival within the error).
- `PhysicsWarning`: the result is computed as asked but is physically meaningless (penetration
  far beyond the clearance, motion whose periodicity cannot be judged).
- `CacheWarning`: the compiled-kernel cache cannot be used (read-only install); the package
  works without it, caching in a private temporary directory. Also: a damaged cache file was
  dropped (its kernels compile again), or a generated model's text did not match its
  recorded digest (it is generated again, never executed).
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
    """The compiled-kernel cache is unavailable (kernels are cached in a private temporary
    directory instead, see the user guide), or a damaged cache entry or generated model was
    dropped and is made again."""
