"""The next job a re-cut hands on: what `compensate` writes so that the next `measure` and
`compensate` take it with no hand editing (`--from DIR`).

Two files in the re-cut's directory:
- job.toml: a configuration every command takes (--config): the one it was run with, the
  tool's nose radius replaced by the measured one (what the tool table now holds and the
  program is planned for) and [toolpath] strategy the program's; its comments name what
  was measured and the corrections made at the machine.
- compensate.json: the figures, and under "next_job" the program's strategy, the nose
  radius, the set-up corrections and the re-cut's target (each lobe's offset spline from
  the design, cut_surface.CompensatedLobe), which a configuration key cannot hold.

`target_from_dict` rebuilds the target against the job's design; a target for another
design (radius range, lobe names) is refused with one line.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..cut_surface import CompensatedLobe, CompensatedMirror
from ..design import Mirror
from ..errors import InputError
from ..inputs import read_text

#: The files of a job directory (compensate -o DIR; --from DIR).
JOB_TOML = "job.toml"
JOB_JSON = "compensate.json"


def target_to_dict(target: CompensatedMirror | None) -> dict | None:
    """The re-cut's target as JSON: each lobe's offset spline (knots mm, coefficients mm)."""
    if target is None:
        return None
    return {"lobes": [{"name": lb.name, "offset_knots_mm": list(lb.offset_knots),
                       "offset_coef_mm": list(lb.offset_coef)} for lb in target.lobes]}


def target_from_dict(data: Any, mirror: Mirror, source: str) -> CompensatedMirror | None:
    """The target a job directory's compensate.json names, on `mirror` (the job's design);
    None: the program's usual target."""
    if data is None:
        return None
    try:
        lobes = []
        for k, item in enumerate(data["lobes"]):
            knots = tuple(float(v) for v in item["offset_knots_mm"])
            coef = tuple(float(v) for v in item["offset_coef_mm"])
            if item["name"] != mirror.lobes[k].name:
                raise ValueError(f"lobe {k} is {item['name']!r}")
            if len(knots) != len(coef) + 4 or not all(map(math.isfinite, knots + coef)):
                raise ValueError(f"lobe {item['name']}: {len(knots)} knots and {len(coef)} coefficients")
            if any(b < a for a, b in zip(knots, knots[1:])) or knots[0] < -1e-9 or knots[-1] > mirror.r_max + 1e-9:
                raise ValueError(f"lobe {item['name']}: knots outside 0..{mirror.r_max:g} mm or not sorted")
            lobes.append(CompensatedLobe(mirror.lobes[k], offset_knots=knots, offset_coef=coef))
        if len(lobes) != 2:
            raise ValueError(f"{len(lobes)} lobes")
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise InputError(f"{source}: next_job.target is not a re-cut target of this design ({exc}); "
                         "allowed: the file compensate wrote, with the configuration beside it") from None
    return CompensatedMirror(mirror, lobes[0], lobes[1])


def read_next_job(directory: str | Path, mirror: Mirror) -> tuple[CompensatedMirror | None, str | None]:
    """What a job directory's compensate.json hands on (`--from DIR`): the re-cut's target
    on `mirror` (None: the program's usual one) and the program's strategy (None: not
    named); a file compensate did not write is refused with one line."""
    src = str(Path(directory) / JOB_JSON)
    try:
        data = json.loads(read_text(src, "--from", 64 << 20))
        nxt = data["next_job"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(f"--from {src}: not a job compensate wrote ({exc.__class__.__name__}: {exc}); "
                         "allowed: the directory of `compensate -o DIR`") from None
    return target_from_dict(nxt.get("target"), mirror, src), nxt.get("strategy")
