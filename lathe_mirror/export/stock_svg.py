"""The set-up sheet's stock pictures as inline SVG: the bar's section after an operation
(grey), what the operation removed (orange), the designed part's outline (blue), in the
machine's (r, Z) frame at equal scale, with millimetre axes.

Drawn as text (no plotting library): a picture costs about a millisecond where a
rasterised figure cost half a second and it prints sharp at any size. Every geometry is
snapped to GRID (shapely's set_precision, which also drops the vertices that snapping
makes coincide and the slivers it collapses) and put in shapely's normal form (rings
from their lowest point, one way round, in order) before it is drawn: the stock after
many set operations may carry two vertices a few nanometres apart on one machine and
one on another (numpy's AVX-512 sin/cos differ from its AVX2 ones in the last bit),
and neither may change the picture's bytes.
"""

from __future__ import annotations

import html
import math

#: Pixels per millimetre at the picture's natural size (it scales with the page).
PX_PER_MM = 9.0
#: The frame's margins around the plot area, px: left, right, top, bottom.
MARGIN = (52.0, 12.0, 26.0, 40.0)
STOCK, REMOVED, PART = "#b8b8b8", "#f39c34", "#1f5fbf"
#: The drawing's precision, mm: 0.009 px at PX_PER_MM, below the 0.001 px the
#: coordinates are written at; a last-bit drift moves a vertex across a rounding
#: boundary of this grid with a probability of about 1e-11.
GRID = 1e-3


def snapped(geom):
    """geom (shapely) on GRID, in normal form: the same drawing from any last bits."""
    import shapely

    if geom is None or geom.is_empty:
        return geom
    return shapely.normalize(shapely.set_precision(geom, GRID))


def polygons(geom) -> list:
    """The polygons of a shapely geometry (Polygon, MultiPolygon, collection)."""
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    return [g for part in getattr(geom, "geoms", []) for g in polygons(part)]


def nice_step(span: float, target: int = 6) -> float:
    """A 1-2-5 tick step giving about `target` ticks over span."""
    raw = span / max(target, 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    return next(m * mag for m in (1.0, 2.0, 5.0, 10.0) if m * mag >= raw)


def stock_svg(stock_after, removed, part, xlim: tuple[float, float], zlim: tuple[float, float],
              title: str, ident: str) -> str:
    """One picture: shapely geometries in (r, Z) mm, the window xlim x zlim (mm). ident:
    unique on the page (the picture's clip path is named by it)."""
    (x0, x1), (z0, z1) = xlim, zlim
    left, right, top, bottom = MARGIN
    w, h = (x1 - x0) * PX_PER_MM, (z1 - z0) * PX_PER_MM
    width, height = left + w + right, top + h + bottom

    def X(x: float) -> str:
        return f"{left + (x - x0) * PX_PER_MM:.3f}"

    def Y(z: float) -> str:
        return f"{top + (z1 - z) * PX_PER_MM:.3f}"

    def ring(coords) -> str:
        pts = list(coords)
        return "M" + "L".join(f"{X(x)} {Y(z)}" for x, z in pts) + "Z"

    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{width:.0f}' height='{height:.0f}' "
           f"viewBox='0 0 {width:.3f} {height:.3f}' font-family='sans-serif' font-size='10'>",
           f"<title>{html.escape(title)}</title>",
           f"<clipPath id='clip-{ident}'><rect x='{left:.3f}' y='{top:.3f}' width='{w:.3f}' height='{h:.3f}'/></clipPath>",
           f"<g clip-path='url(#clip-{ident})'>"]
    for geom, colour in ((stock_after, STOCK), (removed, REMOVED)):
        for poly in polygons(snapped(geom)):
            d = ring(poly.exterior.coords) + "".join(ring(i.coords) for i in poly.interiors)
            out.append(f"<path d='{d}' fill='{colour}' fill-rule='evenodd' stroke='none'/>")
    for poly in polygons(snapped(part)):
        out.append(f"<path d='{ring(poly.exterior.coords)}' fill='none' stroke='{PART}' stroke-width='0.8'/>")
    out.append("</g>")
    out.append(f"<rect x='{left:.3f}' y='{top:.3f}' width='{w:.3f}' height='{h:.3f}' fill='none' "
               "stroke='black' stroke-width='0.8'/>")
    for lo, hi, axis in ((x0, x1, "x"), (z0, z1, "z")):
        step = nice_step(hi - lo)
        k = math.ceil(lo / step - 1e-9)
        while k * step <= hi + 1e-9:
            v = k * step
            label = f"{v:.10g}" if abs(v) > 1e-12 else "0"
            if axis == "x":
                out.append(f"<line x1='{X(v)}' y1='{top + h:.3f}' x2='{X(v)}' y2='{top + h + 4:.3f}' stroke='black'/>"
                           f"<text x='{X(v)}' y='{top + h + 15:.3f}' text-anchor='middle'>{label}</text>")
            else:
                out.append(f"<line x1='{left - 4:.3f}' y1='{Y(v)}' x2='{left:.3f}' y2='{Y(v)}' stroke='black'/>"
                           f"<text x='{left - 6:.3f}' y='{Y(v)}' text-anchor='end' dominant-baseline='middle'>"
                           f"{label}</text>")
            k += 1
    out.append(f"<text x='{left + w / 2:.3f}' y='{height - 6:.3f}' text-anchor='middle'>r (mm)</text>")
    out.append(f"<text transform='translate(12 {top + h / 2:.3f}) rotate(-90)' text-anchor='middle'>Z (mm)</text>")
    out.append(f"<text x='{left + w / 2:.3f}' y='16' text-anchor='middle' font-size='11'>{html.escape(title)}</text>")
    out.append("</svg>")
    return "".join(out)
