"""The typed Settings back to the configuration dict, in the file's units and names
(degrees, m, urad, named choices as their strings): `to_config(settings)`.

It is how a Settings built or varied in Python (`dataclasses.replace`) is held to the same
declared checks as a configuration file (settings.validate), and it writes back any
Settings as the TOML keys it came from (declared.section.dump: each field at its key).
`design_config` is the design's part alone (the camera and the lobes), which a design
file carries.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..declared.section import dump

if TYPE_CHECKING:
    from ..design import Camera, LobeSpec
    from .sections import Sections as Settings


def design_config(camera: Camera, lobes: tuple[LobeSpec, ...]) -> dict[str, Any]:
    """[camera] and [lobes.*] as the configuration dict holds them (a lobe's unset
    choices, e.g. a_over_b beside alpha_deg, left out)."""
    cfg = dump(camera)
    for spec in lobes:
        dump(spec, cfg, star=spec.name)
    return cfg


def to_config(s: Settings) -> dict[str, Any]:
    """The configuration dict whose from_config gives `s` (angles in degrees, ranges in m,
    squareness in urad as the file has them)."""
    cfg = dump(s)
    cfg.update(design_config(s.camera, s.lobes))
    return cfg
