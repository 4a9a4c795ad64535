"""The report's section on the optics shop's specification (iso10110.PartSpec.to_dict()):
each lobe's ISO 10110-12 conic, its form tolerance (ISO 10110-5), the texture (ISO 10110-8),
and the sag tables folded away. The typed spec in, HTML out."""

from __future__ import annotations

import html
from typing import TYPE_CHECKING

from ..iso10110 import CONVENTION

if TYPE_CHECKING:
    from ..iso10110 import PartSpec


def spec_html(spec: PartSpec | None) -> str:
    """The section's HTML; a line saying it is missing when the spec was not computed."""
    if spec is None:
        return "<p class='missing'>(specification: not computed)</p>"
    e = html.escape
    lobes = spec.lobes
    rows = [
        ("vertex radius R [mm]", lambda lb: f"{lb.conic.R:.6f}"),
        ("curvature c = 1/R [1/mm]", lambda lb: f"{lb.conic.curvature:.8f}"),
        ("conic constant k", lambda lb: f"{lb.conic.k:.8f}"),
        ("vertex Z [mm] (Z0 at the inner vertex)", lambda lb: f"{lb.conic.vertex_z:.4f}"),
        ("vertex above the pinhole [mm]", lambda lb: f"{lb.conic.above_pinhole:.4f}"),
        ("clear aperture r [mm]", lambda lb: f"{lb.conic.clear_aperture[0]:.3f} .. {lb.conic.clear_aperture[1]:.3f}"),
        ("focal distance 2e [mm] (Table 1's c)", lambda lb: f"{lb.conic.focal_distance_2e:.4f}"),
        ("form (ISO 10110-5)", lambda lb: e(lb.form.iso10110_5)),
        ("slope error RMS", lambda lb: f"&lt; {lb.form.slope_urad:g} urad per "
                                       f"{lb.form.evaluation_length_mm:g} mm "
                                       f"({e(lb.form.governed_by)} limit)"),
    ]
    head = "<tr><th></th>" + "".join(f"<th>{e(lb.conic.name)}</th>" for lb in lobes) + "</tr>"
    body = "".join(f"<tr><th>{label}</th>" + "".join(f"<td>{fn(lb)}</td>" for lb in lobes) + "</tr>"
                   for label, fn in rows)
    fin = spec.finish
    out = [f"<p>{e(CONVENTION)}</p>", f"<table>{head}{body}</table>",
           f"<p>Texture (ISO 10110-8): <code>{e(fin.iso10110_8)}</code> (Rq {fin.rq_nm:g} nm in the "
           f"band {fin.band_mm[0]:g} to {fin.band_mm[1]:g} mm, TIS {fin.tis * 100:.2f} % at "
           f"{fin.wavelength_nm:g} nm); turned: kinematic Rz {fin.kinematic_rz_um:.3f} um, Ra "
           f"{fin.kinematic_ra_um:.3f} um, the feed marks a grating of period {fin.grating_period_mm:g} mm "
           f"(first order at {fin.grating_order_angle_mrad:.1f} mrad). Material: {e(spec.material)}. "
           f"Process: {e(spec.process)}. The drawing: mirror_drawing.pdf / .svg beside this report "
           "(<code>lathe-mirror spec -o DIR</code>).</p>"]
    out += [f"<p>{e(n)}</p>" for n in spec.notes]
    for lb in lobes:
        trs = "".join(f"<tr><td>{r:.3f}</td><td>{z:.6f}</td><td>{s:.5f}</td></tr>" for r, z, s in lb.sag_table)
        out.append(f"<details><summary>sag table, {e(lb.conic.name)} lobe ({len(lb.sag_table)} rows)</summary>"
                   f"<table><tr><th>r mm</th><th>sag mm</th><th>slope rad</th></tr>{trs}</table></details>")
    return "\n".join(out)
