"""The polishing keys: Preston's law, the lap, the time, the objective, the process presets.

Declared once here (declared.key.Key): type (from the default), unit, default, range,
the reason for the limit, help text. lathe_mirror.declared gathers every module's KEYS.
"""

from __future__ import annotations

from .key import Key

#: Sections declared here: polish.
KEYS: tuple[Key, ...] = (
    Key('polish.preston_coefficient', 4e-13, '1/Pa', 1e-16, 1e-09,
        help='k_p, 1/Pa (m^2/N): removal rate = k_p * pressure * velocity',
        lo_depends=False,
        hi_depends=True,
        depends="the polishing's time steps (polish.time_steps: polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm with time_s, curve_max_s) and the tolerance analysis' estimate"),
    Key('polish.pressure_kpa', 30.0, 'kPa', 0.0, 1000.0, lo_open=True, help='mean pad pressure p0, kPa',
        lo_depends=False,
        hi_depends=True,
        depends="the polishing's time steps (polish.time_steps: polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm with time_s, curve_max_s) and the tolerance analysis' estimate"),
    Key('polish.pad_size_mm', 6.0, 'mm', 0.0, 100.0,
        lo_open=True,
        help=('w: the length over which the pad conforms to the surface, mm (a Gaussian-weighted local cubic fit, '
              'sigma = w / 4)'),
        lo_depends=True,
        depends='polish.grid_step_mm at most pad_size_mm / 8'),
    Key('polish.compliance_mm', 0.004, 'mm', 0.0, 10.0,
        lo_open=True,
        help='pad deflection that doubles the local pressure (p0 / stiffness), mm',
        lo_depends=True,
        hi_depends=False,
        depends="the polishing's time steps (polish.time_steps: polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm with time_s, curve_max_s) and the tolerance analysis' estimate"),
    Key('polish.spindle_rpm', 3000.0, 'rev/min', 0.0, 10000.0, lo_open=True, help='part speed, rev/min',
        lo_depends=False,
        hi_depends=True,
        depends="the polishing's time steps (polish.time_steps: polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm with time_s, curve_max_s) and the tolerance analysis' estimate"),
    Key('polish.time_s', 26400.0, 's', 0.0, 1000000.0,
        why='the polishing estimate bounds the steps',
        help=('polishing time (s per lobe) that `lathe-mirror polish` reports and precompensate plans for (the '
              'report polishes for the time the objective chooses: 440 min on the paper default)')),
    Key('polish.grid_step_mm', 0.005, 'mm', 0.0005, 0.1,
        why='',
        help='radial step of the evolution grid, mm (resolves the 0.005 mm lattice)',
        depends='at most polish.pad_size_mm / 8; the polishing estimate'),
    Key('polish.curve_max_s', 28800.0, 's', 0.0, 1000000.0,
        lo_open=True,
        help='the polishing curve explores 0 .. curve_max_s, s'),
    Key('polish.curve_points', 25, "", 3, 1000, help='number of times on the polishing curve'),
    Key('polish.form_degree', 4, "", 0, 12, help='degree of the low-order (Legendre in r) fit per lobe: "form"'),
    Key('polish.corner_mm', 0.5, 'mm', 0.0, 5.0,
        help=("band at the foot of the step (the recessed lobe: the wall and the tool's fillet) out of the pad's "
              'contact, left as machined, mm')),
    Key('polish.lap', 'rotate',
        choices='rotate, stroke, fixed',
        help=('"rotate": a full-size lap spinning on its own axis, its centre stroked up to stroke_mm off the '
              'part\'s axis (even removal, the vertex included); "stroke": a sub-aperture lap of lap_radius_mm '
              'stroked across the lobe; "fixed": a lap held still over the lobe (v = omega r, nothing at the '
              'vertex)')),
    Key('polish.lap_rpm', 3000.0, 'rev/min', -10000.0, 10000.0,
        help=('lap speed on its own axis, rev/min (= spindle_rpm: synchronous, the speed omega * c is the same '
              'under the whole lap; negative: against the part)'),
        lo_depends=True,
        hi_depends=True,
        depends="the polishing's time steps (polish.time_steps: polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm with time_s, curve_max_s) and the tolerance analysis' estimate"),
    Key('polish.stroke_mm', 0.75, 'mm', 0.0, 100.0,
        help=("rotate: largest offset of the lap's centre, mm (in the recessed lobe's pocket the lap's radius is "
              "the pocket's less this, so its rim, 2 * stroke_mm from the wall, stays off the used zone)"),
        lo_open=True,
        why="the rotating lap's centre moves"),
    Key('polish.lap_radius_mm', 8.0, 'mm', 0.0, 100.0,
        lo_open=True,
        help="stroke: the sub-aperture lap's radius, mm"),
    Key('polish.overhang', 0.3, "", 0.0, 0.5, help="stroke: fraction of the lap's radius it may pass a free edge",
        why="of the lap's radius"),
    Key('polish.dwell', 'uniform',
        choices='uniform, flat',
        help=('dwell-time profile of the stroke: "uniform" (constant speed) or "flat" (the non-negative dwell '
              'making the removal most even)')),
    Key('polish.stroke_points', 16, "", 2, 200, help="nodes of the stroke's piecewise-linear dwell density"),
    Key('polish.step_edge_mm', 0.0, 'mm', 0.0, 5.0,
        help="band at the step's top edge (the proud lobe) out of the pad's contact, mm"),
    Key('polish.clear_edge_mm', 0.5, 'mm', 0.0, 5.0,
        help=('band at each edge of a lobe (step, rim) left out of every slope and form figure (the clear '
              'aperture), mm')),
    Key('polish.objective', 'stereo',
        choices='stereo, image_displacement, slope_error',
        help=('what chooses the time: "stereo" (the calibrated stereo residual), "image_displacement" or '
              '"slope_error"')),
    Key('polish.objective_range_m', 2.0, 'm', 0.2, 100.0, help='range of the stereo objective, m'),
    Key('polish.objective_tolerance', 0.05, "", 0.0, 1.0,
        help='the chosen time is the earliest within this fraction of the least value the explored range reaches'),
    Key('polish.calibration_knot_px', 24.0, 'px', 4.0, 500.0,
        help='knot spacing of the per-lobe radial spline calibration absorbs, px',
        why='a spline the calibration can fit'),
    Key('polish.precompensate', False,
        choices='true, false',
        help=('true: the finishing programs (G-code) cut the design lowered by the removal of time_s, so the '
              'polished part lands on the design')),
    Key('polish.wavelength_nm', 550.0, 'nm', 100.0, 20000.0, help='light of the scatter figures, nm'),
    Key('polish.process.*',
        {'conventional': {'label': 'conventional turning (the configured lathe and tool) + polish',
                          'program': 'paper',
                          'nose_radius_mm': 0.0,
                          'feed_mm': 0.0,
                          'resolution_mm': 0.0,
                          'turned_floor_nm': 20.0,
                          'polish': True,
                          'polished_floor_nm': 3.0},
         'diamond': {'label': 'single-point diamond turning of aluminium, no polish',
                     'program': 'best',
                     'nose_radius_mm': 0.5,
                     'feed_mm': 0.003,
                     'resolution_mm': 0.0001,
                     'turned_floor_nm': 5.0,
                     'polish': False,
                     'polished_floor_nm': 0.0},
         'nickel_diamond': {'label': 'electroless nickel plate, then diamond turning, no polish',
                            'program': 'best',
                            'nose_radius_mm': 0.5,
                            'feed_mm': 0.002,
                            'resolution_mm': 0.0001,
                            'turned_floor_nm': 1.5,
                            'polish': False,
                            'polished_floor_nm': 0.0}},
        choices=('a table per process: label, program (paper, best), nose_radius_mm, feed_mm, resolution_mm (0: the'
                 ' configured one), turned_floor_nm, polish, polished_floor_nm')),
)
