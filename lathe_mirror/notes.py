"""The notes the report carries (filled in by pipeline.report_figures): what a reader needs to know to read the figures right.

Each is a format string; pipeline.report_figures fills in the design's facts (r_used,
rho_used, baseline, angle_2m).
"""

#: What a reader needs to know to read the figures right.
NOTES = (
    "Optical figures count, per lobe, the pixel centres whose exact and made rays land on the "
    "lobe and leave it unobstructed; on this design the step wall vignettes the inner lobe's "
    "reflected rays beyond r = {r_used:.2f} mm (image radius {rho_used:.0f} px), so those pixels show the wall, "
    "not the world, and are left out (each lobe's usable annulus, as optics.distortion counts it; "
    "its per-pixel figures, with those pixels counted too under with_vignetted, are kept "
    "alongside under optics_distortion).",
    "Slope error in the tolerance spec and on the polishing curve is over the radii the image "
    "uses (the inner lobe up to the vignetting radius, where the tool's corner fillet also lies); "
    "the toolpath tables give it over whole lobes (toolpath.profile_errors).",
    "Depth error: a point at range R from the stereo centre is imaged at the exact design's pixel "
    "by each lobe; the made mirror's rays through those two pixels are crossed; error = 100 "
    "(R_made - R) / R. With a {baseline:.1f} mm baseline the two rays meet at only {angle_2m:.2f} deg at 2 m "
    "(the parallax gamma), and a difference delta between the two lobes' ray errors gives "
    "R_made / R = gamma / (gamma - delta): where delta nears gamma the rays turn parallel and the error "
    "diverges, past it they cross behind. So each point's |error| is capped at 100 % (no usable depth, "
    "like a point one lobe does not see; 'failed' counts them) before the RMS over the band: uncapped, "
    "the RMS of a mirror whose delta crosses gamma in the band grows without bound as the band is "
    "sampled more finely (it is set by whichever sample falls nearest the pole), while the capped RMS "
    "and the median converge. What carries a polished mirror's depth error is the facets the polish "
    "has not yet worn away (the lattice steps, about one pixel apart in the image), not the form "
    "change it adds: the form tilts both lobes' rays alike and barely moves the parallax, and a "
    "calibration absorbs what is left of it (section 7 splits the two: the design carrying the form "
    "alone against the design carrying the facets alone). So the polishing time is chosen by the "
    "calibrated stereo residual (polish.objective), not by the image displacement, which counts the "
    "form calibration absorbs.",
    "Polishing: the lap's kinematics set the removal along r (polish.lap; the default, a full-size lap "
    "spinning with the part on its own axis and stroked off centre, rubs every point under it at the "
    "same speed, the vertex included; the first model's lap held still removed nothing at the vertex, "
    "so there the facets outlasted those at the rim). The band at the foot of the step "
    "(polish.corner_mm) is out of the pad's reach and stays as machined; a point deeper than the pad "
    "reaches (the rounded top of the step, a groove) is out of contact and does not pull the pad. "
    "Slope and form figures on the polishing curve are over the clear aperture (polish.clear_edge_mm "
    "from each edge).",
    "Monte Carlo: machined surfaces are precomputed at tolerance.lattice_phases lattice phases "
    "(the Z work zero's offset on the controller's lattice) x 5 nose radii, each polished once "
    "with snapshots at 5 times; a trial interpolates linearly between them, shifts the surface "
    "by the tool setting errors, and is traced in 3-D through its misaligned camera on a sparse "
    "pixel sample (tolerance.bin_px image-radius bins x tolerance.azimuths azimuths, weighted "
    "by pixel counts).",
)
