"""Typed results: each stage's figures as frozen dataclasses (`to_dict()` gives the JSON
the report writes, `from_dict()` reads it back, `table()` a numpy structured array where
a result is a table).

- base.py       the machinery (Result, Range, Stat; to_dict / from_dict)
- design.py     the design's figures
- made.py       toolpaths, machine, zones, each made mirror's figures per lobe
- optics.py     stereo depth error, calibration, renders, range from the image
- polishing.py  the polishing study (curves, form against facets, pre-compensation, processes)
- tolerance.py  the tolerance analysis (Monte Carlo, sensitivity, allocation, verdict)
"""

from .base import Range, Result, Stat
from .design import DesignFigures, LobeDesign
from .made import (DistortionFigures, LobeFigures, MachineFigures, MadeMirror, MirrorFigures, ToolpathFigures,
                   ZoneFigures)
from .optics import (CalibrationFigures, DepthAt, DepthCurve, RangeFigures, RangingFigures, RenderFigures,
                     StereoFigures)
from .polishing import PolishCurveFigures, PolishingStudy
from .tolerance import MonteCarloFigures, ProgramTolerance, ToleranceAnalysis, Verdict

__all__ = ["CalibrationFigures", "DepthAt", "DepthCurve", "DesignFigures", "DistortionFigures", "LobeDesign",
           "LobeFigures",
           "MachineFigures", "MadeMirror", "MirrorFigures", "MonteCarloFigures", "PolishCurveFigures",
           "PolishingStudy", "ProgramTolerance", "Range", "RangeFigures", "RangingFigures", "RenderFigures",
           "Result", "Stat", "StereoFigures", "ToleranceAnalysis", "ToolpathFigures", "Verdict", "ZoneFigures"]
