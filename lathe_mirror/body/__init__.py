"""The mirror's solid as plain data: the design's and the program's meridians on a body.

- meridian.py    Segment, Meridian, BodySpec; the designed face (design_meridian) and
                 closing any face into the body's loop (close_body)
- programmed.py  the programmed face: the toolpath's nose-centre moves offset back by
                 the nose (programmed_contour, programmed_parts)

The CAD writers (export/step.py, mesh.py, dxf.py) revolve or draw a Meridian.
"""

from .meridian import (
                       MAX_LENGTH,
                       STL_TOLERANCE_RANGE,
                       BodySpec,
                       CadModel,
                       CadSettings,
                       Meridian,
                       Role,
                       Segment,
                       SegmentKind,
                       arc_chords,
                       check_product_name,
                       check_stl_tolerance,
                       close_body,
                       design_meridian,
                       programmed_meridian,
)
from .programmed import moves_as_segments, programmed_contour, programmed_parts, segment_tangent

__all__ = ["MAX_LENGTH", "STL_TOLERANCE_RANGE", "BodySpec", "CadModel", "CadSettings", "check_product_name", "check_stl_tolerance", "Meridian", "Role", "Segment", "SegmentKind", "arc_chords", "close_body",
           "design_meridian", "programmed_meridian", "moves_as_segments", "programmed_contour",
           "programmed_parts", "segment_tangent"]
