"""The design search's keys: objective, envelope, band, image, search ranges.

Declared once here (declared.key.Key): type (from the default), unit, default, range,
the reason for the limit, help text. lathe_mirror.declared gathers every module's KEYS.
"""

from __future__ import annotations

from .key import Key

#: Sections declared here: optimize.
KEYS: tuple[Key, ...] = (
    Key('optimize.objective', 'delivered_r10_p5',
        choices='delivered_r10_p5, r10, baseline, band_width, usable_area',
        help=("delivered_r10_p5: the R10 (m) the made parts deliver at their 5th percentile (R10 over the matcher's "
              "noise on the blurred image and the parts' own disparity error, a seeded Monte Carlo's of the "
              "configured design; the winner's confirmed by the full Monte Carlo); "
              'r10: range (m) at which 1 px of disparity costs 10 % of range, median over band_deg (the stereo '
              'model, optics.ranging.resolution); baseline: F1 to F1 (mm); band_width: the common band (deg); '
              "usable_area: share of the inscribed circle's pixels that see the scene")),
    Key('optimize.seed', 1, "", 0, 4294967295, help="differential evolution's seed: same seed, same design"),
    Key('optimize.workers', 1, "", 1, 64, help='processes evaluating each generation (--workers overrides)'),
    Key('optimize.popsize', 15, "", 5, 100,
        why="the optimiser's estimate bounds it with maxiter",
        help='population per searched parameter (x 6 = 90 designs per generation)'),
    Key('optimize.maxiter', 500, "", 1, 5000,
        why="the optimiser's estimate bounds it with popsize",
        help='generations at most (about 0.5-1 ms per design per process; the default search converges in 300-400)'),
    Key('optimize.tol', 0.001, "", 0.0, 1.0,
        lo_open=True,
        hi_open=True,
        help="stop when the population's objective spreads less than this (relative)"),
    Key('optimize.r_max_mm', 35.0, 'mm', 0.0, 10000.0,
        lo_open=True,
        help="radial: the outer rim's radius (outer r_top) at most this (paper 35)"),
    Key('optimize.vertex_min_mm', 103.6, 'mm', 0.0, 10000.0,
        lo_open=True,
        help='axial: the vertex (nearest point) at least this far from the pinhole (paper 103.678)',
        hi_depends=True,
        depends='below optimize.rim_max_mm'),
    Key('optimize.rim_max_mm', 123.5, 'mm', 0.0, 10000.0,
        lo_open=True,
        why='',
        help=('axial: the farthest point (the higher rim) at most this far (paper 123.457); vertex_min_mm + 35 '
              'allows 35 mm of mirror depth'),
        lo_depends=True,
        depends='above optimize.vertex_min_mm'),
    Key('optimize.band_deg', [-20.0, 0.0], 'deg', -90.0, 90.0,
        length=(2, 2),
        why='lowest < highest',
        help='elevations (lowest, highest) the common band must cover (paper -25.77 .. 0.03)'),
    Key('optimize.band_width_min_deg', 0.0, 'deg', 0.0, 180.0,
        hi_open=True,
        help='and its width at least this (deg)'),
    Key('optimize.rim_margin_px', 0.0, 'px', 0.0, 100000.0,
        help="the outer rim's image this far inside the sensor's inscribed circle"),
    Key('optimize.usable_min', 0.8, "", 0.0, 1.0,
        help=("share of the inscribed circle's pixels that see the scene, after the ring lost at the junction and "
              "the step's vignetting (paper 0.926)")),
    Key('optimize.blur_max_px', 7.0, 'px', 0.0, 100000.0,
        lo_open=True,
        help='largest blur circle over both usable annuli (paper 6.64 px at f/8)'),
    Key('optimize.focus_range_m', 2.0, 'm', 0.05, 1000000.0,
        help='range of the scene points whose virtual images are in focus'),
    Key('optimize.max_diameter_mm', 0.0, 'mm', 0.0, 20000.0,
        why='0: optimize.r_max_mm holds',
        help=("the mirror's largest diameter, mm (0: r_max_mm holds; given, it or max_depth_mm replaces "
              "vertex_min_mm too: the heights above the pinhole follow from the design)")),
    Key('optimize.max_depth_mm', 0.0, 'mm', 0.0, 10000.0,
        why='0: optimize.rim_max_mm holds',
        help="the mirror's largest depth, vertex to the higher rim, mm (0: rim_max_mm holds)"),
    Key('optimize.blur_limit_um', 63.0, 'um', 0.0, 100000.0,
        why='0: optimize.blur_max_px holds',
        help=("largest blur circle on the sensor, um, the same for any pixel pitch (63 um: 7 px of the paper's "
              "9 um pixels; 0: blur_max_px holds); the winner keeps bound_margin below it")),
    Key('optimize.bound_margin', 0.02, "", 0.0, 0.25,
        why="of each searched parameter's span",
        help="fraction of each searched parameter's span the winner keeps clear of its bounds"),
    Key('optimize.search.outer_r_top_fraction', [0.5, 1.0], "", 0.0, 1.0,
        lo_open=True,
        length=(2, 2),
        why='low <= high',
        help='outer r_top / r_max_mm'),
    Key('optimize.search.junction_fraction', [0.15, 0.9], "", 0.0, 1.0,
        lo_open=True,
        hi_open=True,
        length=(2, 2),
        why='low <= high',
        help='inner r_top / outer r_top'),
    Key('optimize.search.outer_r_pixel_fraction', [0.5, 1.0], "", 0.0, 1.0,
        lo_open=True,
        length=(2, 2),
        why='low <= high',
        help='outer r_pixel / (inscribed radius - rim_margin_px)'),
    Key('optimize.search.pixel_fraction', [0.15, 0.95], "", 0.0, 1.0,
        lo_open=True,
        hi_open=True,
        length=(2, 2),
        why='low <= high',
        help='inner r_pixel / outer r_pixel'),
    Key('optimize.search.alpha_inner_deg', [-20.0, 60.0], 'deg', -89.0, 89.0,
        length=(2, 2),
        why='low <= high',
        help="Table 1's alpha of each lobe (deg)"),
    Key('optimize.search.alpha_outer_deg', [-30.0, 30.0], 'deg', -89.0, 89.0, length=(2, 2), why='low <= high'),
)
