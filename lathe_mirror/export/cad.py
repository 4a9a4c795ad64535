"""CAD files of a model: meridian -> STEP / STL / DXF bytes -> files, read back and checked.

`export_cad` is what `lathe-mirror cad` calls with the model job.cad_model built;
`write_reference_cad` writes the paper mirror's reference files into `cad/` (the main job
regenerates them; a test checks they are current). Machine frame and mm throughout
(ARCHITECTURE.md).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from ..body import CadModel, CadSettings
from ..enums import CadFormat, Which
from ..errors import InputError
from .dxf import audit, dxf_bytes
from .files import check_writable, prepare_dir, write_bytes
from .mesh import mesh_figures, stl_bytes
from .step import read_step, solid_figures, step_bytes

#: File name suffixes that imply a format when --format is not given.
SUFFIXES = {".step": CadFormat.STEP, ".stp": CadFormat.STEP, ".stl": CadFormat.STL,
            ".dxf": CadFormat.DXF}

#: The reference files of the paper mirror, written by write_reference_cad.
REFERENCE_FILES = ("mirror_design.step", "mirror_programmed.step", "mirror_profile.dxf")


def cad_bytes(model: CadModel, which: Which, fmt: CadFormat, settings: CadSettings) -> bytes:
    """The file's bytes (deterministic for a given model and settings)."""
    meridian = model.design if which is Which.DESIGN else model.programmed
    if meridian is None:
        raise RuntimeError("cad_bytes: the model was built without the programmed mirror")
    if fmt is CadFormat.STEP:
        return step_bytes(meridian, schema=settings.schema, product_name=settings.product_name)
    if fmt is CadFormat.STL:
        return stl_bytes(meridian, settings.stl_tolerance)

    return dxf_bytes(model.mirror, model.design, programmed=model.programmed,
                     tool_centre=model.tool_centre)


def export_cad(model: CadModel, settings: CadSettings, which: Which, fmt: CadFormat,
               path: str | Path) -> dict[str, Any]:
    """Write one CAD file of `model`; returns its figures (JSON-ready). Nothing is written
    on bad input; a file that fails its own read-back check (check_file, ok_figures) is
    removed and RuntimeError raised (an internal failure, exit 1). The model must hold the
    programmed face for Which.PROGRAMMED and for a DXF (its toolpath layers)."""
    check_target(path)
    data = cad_bytes(model, which, fmt, settings)
    # Read the bytes back from a scratch copy before the real file is written: the command's
    # files are written only when it succeeds (files.staging), and a bad file never is.
    import tempfile

    with tempfile.TemporaryDirectory(prefix="lathe-mirror-check-") as tmp:
        scratch = Path(tmp) / f"check.{fmt.value}"
        scratch.write_bytes(data)
        check = check_file(scratch, fmt)
    if not ok_figures(check, fmt):
        raise RuntimeError(f"{fmt.value} of the {which.value} mirror failed its read-back "
                           f"check {check}; nothing written")
    try:
        write_bytes(path, data)
    except OSError as exc:  # e.g. /proc, a read-only file system: os.access said yes
        raise InputError(f"-o/--output {path}: cannot write ({exc.strerror})") from None
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


def check_target(path: str | Path) -> None:
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
        return solid_figures(read_step(path))
    if fmt is CadFormat.STL:
        import trimesh

        return mesh_figures(trimesh.load(str(path), file_type="stl", validate=True))

    return {"audit_errors": audit(path)}


def ok_figures(check: dict[str, Any], fmt: CadFormat) -> bool:
    """Whether check_file's figures pass: one valid STEP solid, a watertight STL, a DXF
    without audit errors."""
    if fmt is CadFormat.STEP:
        return check["solids"] == 1 and check["valid"]
    if fmt is CadFormat.STL:
        return check["watertight"] and check["winding_consistent"] and check["volume_mm3"] > 0
    return not check["audit_errors"]


def reference_cad_bytes(model: CadModel, settings: CadSettings) -> dict[str, bytes]:
    """The bytes of a model's reference CAD, by file name (REFERENCE_FILES): the designed
    and the programmed STEP and the meridian DXF. The model must hold the programmed face."""
    jobs = [(Which.DESIGN, CadFormat.STEP), (Which.PROGRAMMED, CadFormat.STEP),
            (Which.DESIGN, CadFormat.DXF)]
    return {name: cad_bytes(model, which, fmt, settings) for name, (which, fmt) in zip(REFERENCE_FILES, jobs)}


def write_reference_cad(out_dir: str | Path, model: CadModel, settings: CadSettings, *,
                        data: dict[str, bytes] | None = None) -> list[Path]:
    """Write a model's reference CAD into out_dir (the paper mirror's into `cad/`): the
    designed and the programmed STEP and the meridian DXF (REFERENCE_FILES). The model must
    hold the programmed face. data: reference_cad_bytes's, made already (e.g. in another
    process). Returns the paths."""
    # Every file's bytes first: a failure leaves no mix of new and old reference files.
    data = reference_cad_bytes(model, settings) if data is None else data
    out = prepare_dir(out_dir)
    return [write_bytes(out / name, data[name]) for name in REFERENCE_FILES]
