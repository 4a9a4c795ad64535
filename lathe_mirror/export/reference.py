"""The reference outputs `lathe-mirror run` writes beside its report (on the paper default,
the repository's gcode/, cad/ and calib/): each program in every control's dialect with
its second set-up, set-up sheet and tool tables, the designed and programmed CAD, and the
calibration files of the design."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..design import Mirror
from ..enums import Strategy
from ..job import cad_model
from ..optics.zones import zones_for
from .cad import REFERENCE_FILES, reference_cad_bytes, write_reference_cad
from .calib import FILE_NAMES as CALIB_FILES
from .calib import calibration_texts, write_calibration
from .dialects import dialects
from .files import write_text
from .gcode import program_files

if TYPE_CHECKING:
    from ..settings import Settings

__all__ = ["CALIB_FILES", "REFERENCE_FILES", "cad_and_calibration_files", "program_names",
           "write_cad_and_calibration", "write_programs"]


def program_names(strategies: tuple[Strategy, ...]) -> list[str]:
    """The files write_programs writes for these strategies: each program and its second
    set-up's in every dialect, one set-up sheet a program (the second set-up's program is
    on the first's sheet), each control's tool table."""
    exts = [d.extension for d in dialects()] + ["setup.html"]
    names = [f"mirror_{s.value}{op}.{ext}" for s in strategies for op in ("", "_op2") for ext in exts
             if not (op and ext == "setup.html")]
    return names + [d.offsets_file for d in dialects()]


def write_programs(directory: str | Path, shops: list) -> list[Path]:
    """The checked, simulated programs (shop.programs.ShopProgram) as program_names names
    them, into `directory`; their paths."""
    texts = program_files(shops)
    return [write_text(Path(directory) / name, text) for name, text in texts.items()]


def cad_and_calibration_files(settings: Settings, mirror: Mirror) -> tuple[dict[str, bytes], dict[str, str]]:
    """What write_cad_and_calibration writes, by file name: (the CAD's bytes, the
    calibration files' texts). Plain data: `run` makes them in its background process,
    beside the report's stages, and writes them in its own."""
    return (reference_cad_bytes(cad_model(settings, mirror, programmed=True), settings.cad),
            calibration_texts(mirror, zones_for(settings, mirror)))


def write_cad_and_calibration(cad_dir: str | Path, calib_dir: str | Path, settings: Settings,
                              mirror: Mirror, *, files: tuple[dict[str, bytes], dict[str, str]] | None = None,
                              ) -> tuple[list[Path], list[Path]]:
    """The designed and programmed STEP and the meridian DXF into cad_dir, the calibration
    files over the zones every command uses into calib_dir; (their paths, their paths).
    files: cad_and_calibration_files's, made already."""
    if files is None:
        cad = write_reference_cad(cad_dir, cad_model(settings, mirror, programmed=True), settings.cad)
        return cad, write_calibration(calib_dir, mirror, zones_for(settings, mirror))
    data, texts = files
    cad = write_reference_cad(cad_dir, None, settings.cad, data=data)
    return cad, [write_text(Path(calib_dir) / name, texts[name]) for name in CALIB_FILES]
