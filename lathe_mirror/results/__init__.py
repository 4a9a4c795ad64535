"""Typed results: each stage's figures as frozen dataclasses (`to_dict()` gives the JSON
the report writes, `table()` a numpy structured array where a result is a table).

- base.py       the machinery (Result, Range, Stat; to_dict / from_dict)
- design.py     the design's figures
- made.py       toolpaths, machine, zones, each made mirror's figures per lobe
- optics.py     stereo depth error, calibration, renders, range from the image
"""

from .base import Range, Result, Stat
from .design import DesignFigures, LobeDesign
from .made import LobeFigures, MachineFigures, MadeMirror, MirrorFigures, ToolpathFigures, ZoneFigures
from .optics import (CalibrationFigures, DepthAt, DepthCurve, RangeFigures, RangingFigures, RenderFigures,
                     StereoFigures)

__all__ = ["CalibrationFigures", "DepthAt", "DepthCurve", "DesignFigures", "LobeDesign", "LobeFigures",
           "MachineFigures", "MadeMirror", "MirrorFigures", "Range", "RangeFigures", "RangingFigures",
           "RenderFigures", "Result", "Stat", "StereoFigures", "ToolpathFigures", "ZoneFigures"]
