"""The typed settings: `Settings`, every section of a configuration (settings.sections)
checked on construction: a Settings that cannot exist cannot be built, from a
configuration or in Python (`dataclasses.replace(settings, ...)`), and the message is the
one `load()` gives (settings.validate).
"""

from __future__ import annotations

from dataclasses import dataclass

from .sections import MAX_SUPERSAMPLE, ComputeSettings, RenderSettings, Sections, StereoSettings
from .validate import validate


@dataclass(frozen=True, repr=False)  # Sections' one-line repr
class Settings(Sections):
    """Every section of a configuration (settings.sections.Sections: the fields), checked
    on construction (settings.validate: the keys' ranges, the cross-key rules, the design,
    the room, the costs)."""

    def __post_init__(self) -> None:
        validate(self)  # the one validation, however the Settings was built


__all__ = ["MAX_SUPERSAMPLE", "ComputeSettings", "RenderSettings", "Settings", "StereoSettings"]
