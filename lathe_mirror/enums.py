"""Every named choice of the tool, and the one parser that reads them from a user.

A choice is a `str` Enum, so its value is what a user writes (in TOML or on the command
line) and what the JSON carries. `parse(Enum, value, key)` turns a user's string into the
member or raises one InputError line naming the key and the allowed values. Calling the
enum does the same from Python: `Strategy("best")`, `Strategy("ARCS")` (a value or a
member's name, any case) give the member; anything else raises that InputError.
"""

from __future__ import annotations

from enum import Enum
from typing import TypeVar

from .errors import InputError

E = TypeVar("E", bound=Enum)


class Choice(str, Enum):
    """A named choice: called with a member's value or name (any case) it gives the
    member; with anything else an InputError naming the enum and the allowed values."""

    @classmethod
    def _missing_(cls, value):
        text = str(value).lower()
        for name, member in cls.__members__.items():
            if member.value.lower() == text or name.lower() == text:
                return member
        allowed = list(dict.fromkeys([m.value for m in cls] + [n.lower() for n in cls.__members__]))
        raise InputError(f"{cls.__name__} {_short(value)}: allowed {', '.join(allowed)}")


def member(enum: type[E], value: object, what: str) -> E:
    """value as a member of enum (a member, or its value or name in any case, as calling
    the enum takes it); InputError "what = value: allowed ..." naming the argument."""
    if isinstance(value, enum):
        return value
    try:
        return enum(value)
    except ValueError:
        allowed = list(dict.fromkeys([m.value for m in enum] + [n.lower() for n in enum.__members__]))
        raise InputError(f"{what} = {_short(value)}: allowed {', '.join(allowed)}") from None


def _short(value: object) -> str:
    import reprlib

    return reprlib.repr(value)


class Strategy(Choice):
    """How the exact profile becomes lattice moves (toolpath/). BEST (= ARCS) is the default."""

    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"
    BEST = "arcs"  # an alias of ARCS (Strategy.BEST is Strategy.ARCS), as the CLI's "best"


#: The strategy with the smallest slope error on the paper's machine (toolpath/ package doc).
BEST = Strategy.BEST


class Surface(Choice):
    """Named mirror surfaces (job.named_surface): the exact design, references, the
    programmed contour of each strategy, the polished paper program, a measured part (given
    on the command line as measured:FILE), and made: the configured machining job's made
    mirror (job.MachiningJob.from_settings)."""

    EXACT = "exact"
    REFERENCE = "reference"
    UNIFORM528 = "uniform528"
    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"
    BEST = "best"
    POLISHED = "polished"
    MEASURED = "measured"  # --surface measured:FILE, a measured part (measure.surface)
    MADE = "made"

    @property
    def strategy(self) -> Strategy | None:
        """The toolpath strategy this surface is cut with: its own, best's (BEST), the
        paper's for polished; None for the surfaces no program cuts (exact, reference,
        uniform528, measured) and for made (the configured [toolpath] strategy: MachiningJob)."""
        if self in (Surface.EXACT, Surface.REFERENCE, Surface.UNIFORM528, Surface.MEASURED, Surface.MADE):
            return None
        if self is Surface.POLISHED:
            return Strategy.PAPER
        return BEST if self is Surface.BEST else Strategy(self.value)


class Program(Choice):
    """Which programmed contour a toleranced part is turned from."""

    BEST = "best"
    PAPER = "paper"

    @property
    def strategy(self) -> Strategy:
        """The toolpath strategy this program is planned with (best: BEST)."""
        return BEST if self is Program.BEST else Strategy.PAPER


class Distribution(Choice):
    """How a parameter's tolerance is read when drawing trials."""

    NORMAL = "normal"    # the tolerance is a 3-sigma bound of a normal distribution
    UNIFORM = "uniform"  # uniform within +/- the tolerance


class Mount(Choice):
    """How the mirror is held: a blind bore in the back, a boss (spigot), or nothing."""

    BORE = "bore"
    BOSS = "boss"
    NONE = "none"


class StepSchema(Choice):
    """STEP application protocol: AP214 (automotive design; read by nearly everything)
    or AP242 (managed model-based 3D engineering; newer readers)."""

    AP214 = "AP214"
    AP242 = "AP242"


class Which(Choice):
    """Which mirror a CAD file holds: the design (exact lobes) or the programmed contour."""

    DESIGN = "design"
    PROGRAMMED = "programmed"


class CadFormat(Choice):
    """CAD output format, by file content."""

    STEP = "step"
    STL = "stl"
    DXF = "dxf"


class Lap(Choice):
    """How the polishing lap moves over a lobe (polishing.LapPlan).

    FIXED: a lap covering the whole lobe, held still while the part spins (v = omega r:
    nothing is removed at the vertex; the simplest model, kept for
    comparison). ROTATE: a full-size lap (the recessed lobe's pocket, or past the rim)
    spinning on its own axis, its centre stroked off the part's axis by up to stroke_mm
    with a dwell-time profile (removal at the vertex too). STROKE: a sub-aperture lap of
    lap_radius_mm spinning on its own axis, its centre stroked across the lobe with a
    dwell-time profile."""

    FIXED = "fixed"
    ROTATE = "rotate"
    STROKE = "stroke"


class Dwell(Choice):
    """The dwell-time profile of a stroking lap along r: UNIFORM (a constant stroke speed)
    or FLAT (the non-negative dwell that makes the removal most nearly uniform over the
    lobe's clear aperture, as a deterministic-polishing planner computes it)."""

    UNIFORM = "uniform"
    FLAT = "flat"


class PolishObjective(Choice):
    """The figure that chooses the polishing time (optics.polishing_curve).

    STEREO: the calibrated stereo residual (depth error once a per-lobe smooth radial
    remapping, what calibration absorbs, is fitted out). IMAGE_DISPLACEMENT: RMS image
    displacement over both lobes. SLOPE_ERROR: RMS slope error over the clear aperture of
    both lobes."""

    STEREO = "stereo"
    IMAGE_DISPLACEMENT = "image_displacement"
    SLOPE_ERROR = "slope_error"


def parse(enum: type[E], value: object, key: str, *, aliases: dict[str, E] | None = None) -> E:
    """The member of `enum` whose value is `value` (case-insensitive), or an alias.

    key: what the user wrote it as: a config key ("toolpath.strategy") or a flag
    ("--strategy"). Raises InputError: "<key> = 'x': allowed a, b" (a flag: "<key> 'x':
    allowed a, b").
    """
    text = str(value)
    if aliases and text.lower() in aliases:
        return aliases[text.lower()]
    for member in enum:
        if member.value.lower() == text.lower():
            return member
    allowed = [m.value for m in enum] + sorted(aliases or ())
    sep = " " if key.startswith("-") else " = "
    raise InputError(f"{key}{sep}{value!r}: allowed {', '.join(allowed)}")
