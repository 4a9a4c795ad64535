"""CAD of the mirror end to end: config -> meridian -> STEP / STL / DXF bytes -> files.

`export_cad` is what `lathe-mirror cad` calls; `write_reference_cad` writes the paper
mirror's reference files into `cad/` (the main job regenerates them; a test checks they
are current). Machine frame and mm throughout (ARCHITECTURE.md).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..cad_body import Meridian, Segment, body_spec_from_config, design_meridian
from ..design import Mirror, mirror_from_config
from ..errors import InputError
from .files import check_writable, prepare_dir, write_bytes

if TYPE_CHECKING:
    from .step import StepSchema


class Which(str, Enum):
    """Which mirror: the design (exact lobes) or the toolpath's programmed contour."""

    DESIGN = "design"
    PROGRAMMED = "programmed"


class CadFormat(str, Enum):
    """Output format, by file content."""

    STEP = "step"
    STL = "stl"
    DXF = "dxf"


#: File name suffixes that imply a format when --format is not given.
SUFFIXES = {".step": CadFormat.STEP, ".stp": CadFormat.STEP, ".stl": CadFormat.STL,
            ".dxf": CadFormat.DXF}

#: The reference files of the paper mirror, written by write_reference_cad.
REFERENCE_FILES = ("mirror_design.step", "mirror_programmed.step", "mirror_profile.dxf")


def parse_enum(enum: type[Enum], value: str, what: str) -> Any:
    """enum(value), or InputError naming `what` and the allowed values."""
    try:
        return enum(str(value).lower())
    except ValueError:
        allowed = ", ".join(m.value for m in enum)
        raise InputError(f"{what} {value!r}: unknown; allowed {allowed}") from None


@dataclass(frozen=True)
class CadSettings:
    """The [cad] export settings, checked: STEP protocol and product name, STL tolerance
    (mm, the facets' largest distance from the surface)."""

    schema: StepSchema
    product_name: str
    stl_tolerance: float


def cad_settings_from_config(cfg: dict[str, Any]) -> CadSettings:
    """CadSettings from [cad] (InputError naming the key otherwise). Light: no CAD
    kernel is imported."""
    from .mesh import check_stl_tolerance
    from .step import check_product_name, parse_schema

    c = cfg["cad"]
    return CadSettings(schema=parse_schema(c["step_schema"]),
                       product_name=check_product_name(c["product_name"]),
                       stl_tolerance=check_stl_tolerance(c["stl_tolerance"]))


def check_cad_config(cfg: dict[str, Any]) -> None:
    """Check every [cad] setting and that the body holds the designed mirror, so bad
    input fails before any file is written (what `lathe-mirror run` needs before it
    writes its programs). Takes ~0.3 ms; plans no toolpath, imports no CAD kernel."""
    cad_settings_from_config(cfg)
    design_meridian(mirror_from_config(cfg), body_spec_from_config(cfg))


@dataclass(frozen=True)
class CadModel:
    """The meridians behind every CAD file of one configuration."""

    mirror: Mirror
    design: Meridian
    programmed: Meridian | None
    tool_centre: tuple[Segment, ...] | None
    toolpath_figures: dict[str, Any] | None


def build_model(cfg: dict[str, Any], *, programmed: bool,
                programmed_face_only: bool = False) -> CadModel:
    """The design meridian and, when asked, the programmed one and the tool-centre path
    (these plan the toolpath: lathe_mirror.toolpath).

    programmed_face_only: only the programmed contour is wanted (the design DXF's
    TOOLPATH layer), so it is closed on a body large enough for any program: the finishing
    pass runs a few lattice steps past the rim, and a blank exactly the mirror's diameter
    (a legitimate body for the design) must not stop the design's drawing.
    """
    mirror = mirror_from_config(cfg)
    spec = body_spec_from_config(cfg)
    design = design_meridian(mirror, spec)
    if not programmed:
        return CadModel(mirror, design, None, None, None)
    from dataclasses import replace

    from ..cad_body import MAX_LENGTH, Mount, programmed_parts

    prog_spec = (replace(spec, blank_diameter=MAX_LENGTH, thickness=MAX_LENGTH, mount=Mount.NONE)
                 if programmed_face_only else spec)
    prog, centre, figures = programmed_parts(cfg, mirror, prog_spec)
    return CadModel(mirror, design, prog, centre, figures)


def cad_bytes(model: CadModel, which: Which, fmt: CadFormat, cfg: dict[str, Any]) -> bytes:
    """The file's bytes (deterministic for a given configuration)."""
    settings = cad_settings_from_config(cfg)
    meridian = model.design if which is Which.DESIGN else model.programmed
    if meridian is None:
        raise RuntimeError("cad_bytes: the model was built without the programmed mirror")
    if fmt is CadFormat.STEP:
        from .step import step_bytes

        return step_bytes(meridian, schema=settings.schema, product_name=settings.product_name)
    if fmt is CadFormat.STL:
        from .mesh import stl_bytes

        return stl_bytes(meridian, settings.stl_tolerance)
    from .dxf import dxf_bytes

    return dxf_bytes(model.mirror, model.design, programmed=model.programmed,
                     tool_centre=model.tool_centre)


def export_cad(cfg: dict[str, Any], which: Which, fmt: CadFormat, path: str | Path) -> dict[str, Any]:
    """Write one CAD file; returns its figures (JSON-ready). Nothing is written on bad
    input; a file that fails its own read-back check (check_file, ok_figures) is removed
    and RuntimeError raised (an internal failure, exit 1)."""
    _check_target(path)
    cad_settings_from_config(cfg)
    # The DXF always carries the toolpath layers: it plans the toolpath (and fails, exit
    # 2, on a toolpath setting it cannot plan with, as `lathe-mirror toolpath` would).
    model = build_model(cfg, programmed=(which is Which.PROGRAMMED or fmt is CadFormat.DXF),
                        programmed_face_only=(which is Which.DESIGN))
    data = cad_bytes(model, which, fmt, cfg)
    try:
        write_bytes(path, data)
    except OSError as exc:  # e.g. /proc, a read-only file system: os.access said yes
        raise InputError(f"-o/--output {path}: cannot write ({exc.strerror})") from None
    check = check_file(path, fmt)
    if not ok_figures(check, fmt):
        Path(path).unlink(missing_ok=True)
        raise RuntimeError(f"{fmt.value} of the {which.value} mirror failed its read-back "
                           f"check {check}; nothing written")
    meridian = model.design if which is Which.DESIGN else model.programmed
    out: dict[str, Any] = {
        "which": which.value,
        "format": fmt.value,
        "path": str(path),
        "bytes": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
        "frame": "machine: axis Z, vertex at the origin, part in -Z, mm",
        "volume_mm3": meridian.volume(),
        "features_mm": dict(meridian.features),
    }
    out["check"] = check
    if model.toolpath_figures is not None:
        out["toolpath"] = model.toolpath_figures
    return out


def _check_target(path: str | Path) -> None:
    """InputError unless path can take a new regular file. An existing device, FIFO or
    socket is refused: the atomic write renames over it (as root, `-o /dev/null` would
    replace the system's null device with a regular file)."""
    check_writable(path)
    p = Path(path)
    if p.exists() and not p.is_file():
        raise InputError(f"-o/--output {path}: not a regular file (a device, FIFO or "
                         "socket); allowed a new or an existing regular file")


def check_file(path: str | Path, fmt: CadFormat) -> dict[str, Any]:
    """Read a written file back and check it: STEP (OCC's reader) one valid solid and
    its volume; STL (trimesh) watertight and its volume; DXF ezdxf's audit errors."""
    if fmt is CadFormat.STEP:
        from .step import read_step, solid_figures

        return solid_figures(read_step(path))
    if fmt is CadFormat.STL:
        import trimesh

        from .mesh import mesh_figures

        return mesh_figures(trimesh.load(str(path), file_type="stl", validate=True))
    from .dxf import audit

    return {"audit_errors": audit(path)}


def ok_figures(check: dict[str, Any], fmt: CadFormat) -> bool:
    """Whether check_file's figures pass: one valid STEP solid, a watertight STL, a DXF
    without audit errors."""
    if fmt is CadFormat.STEP:
        return check["solids"] == 1 and check["valid"]
    if fmt is CadFormat.STL:
        return check["watertight"] and check["winding_consistent"] and check["volume_mm3"] > 0
    return not check["audit_errors"]


def write_reference_cad(out_dir: str | Path = "cad", cfg: dict[str, Any] | None = None) -> list[Path]:
    """Write the paper mirror's reference CAD into out_dir: the designed and the
    programmed STEP and the meridian DXF (REFERENCE_FILES). Returns the paths."""
    from ..config import default_config

    cfg = default_config() if cfg is None else cfg
    model = build_model(cfg, programmed=True)
    jobs = [(Which.DESIGN, CadFormat.STEP), (Which.PROGRAMMED, CadFormat.STEP),
            (Which.DESIGN, CadFormat.DXF)]
    # Every file's bytes first: a failure leaves no mix of new and old reference files.
    data = [cad_bytes(model, which, fmt, cfg) for which, fmt in jobs]
    out = prepare_dir(out_dir)
    return [write_bytes(out / name, d) for name, d in zip(REFERENCE_FILES, data)]
