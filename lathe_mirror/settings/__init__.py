"""Settings: the merged configuration as one frozen, typed object, validated once.

`config.load()` merges the user's TOML over the embedded defaults and checks every key's
name and type (config.py); `from_config` turns that checked dict into `Settings`, one
typed object per TOML section, and checks every value (ranges, choices, the design itself).
Each rejection is one InputError line naming the key and what is allowed, and all of it
happens before any command does work or writes a file. Below the command layer nothing sees
the dict: every stage takes the typed objects (Camera, Lathe, Tool, PolishParams, ...).

The package's modules:
  sections       the sections without a lower home, and Sections: every section's field
  model          Settings: Sections checked on construction (validate)
  keys           every key and what it allows (RANGES, check_ranges)
  design_checks  a lobe that is a proper hyperbola, a common stereo band, assembly tolerances
  costs          what the keys cost (time, memory), refused above the limits
  load           from_config: the dict -> Settings (each section from its declared fields)
  dump           to_config: Settings -> the dict (the same fields back, in the file's units)

Bounds: every key has a documented range (RANGES; docs/reference/keys.md), and what a key costs where a hard bound would be arbitrary is estimated from the
keys and refused above a limit with the estimate in the message (check_costs). A
configuration is valid for every command or for none. Checks that need a planned toolpath
or the made surface (the gouge, the stock holding the mirror, the body holding it, the
room holding the camera) stay with the stage that has them.
"""

from __future__ import annotations

from .costs import MEMORY_LIMIT_GIB, MIRRORS_RANGED, TIME_LIMIT_MIN, Cost, check_costs, estimate_costs, limits
from .design_checks import MIN_SEEN, check_assembly_tolerances, check_design, checked_mirror
from .keys import H_RANGE, MAX_ROUGH_LEVELS, MAX_VERTEX_RADIUS, MIN_VERTEX_RADIUS, RANGES, Range, check_ranges
from .load import from_config
from .model import MAX_SUPERSAMPLE, ComputeSettings, RenderSettings, Settings, StereoSettings

__all__ = [
    "H_RANGE", "MAX_ROUGH_LEVELS", "MAX_SUPERSAMPLE", "MAX_VERTEX_RADIUS", "MEMORY_LIMIT_GIB", "MIN_SEEN",
    "MIN_VERTEX_RADIUS", "MIRRORS_RANGED", "RANGES", "TIME_LIMIT_MIN", "ComputeSettings", "Cost", "Range",
    "RenderSettings", "Settings", "StereoSettings", "check_assembly_tolerances", "check_costs", "check_design",
    "checked_mirror",
    "check_ranges", "estimate_costs", "from_config", "limits",
]
