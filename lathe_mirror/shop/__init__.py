"""The shop's side of a program: the whole lathe program around a finishing toolpath,
its simulation against the stock, and the set-up sheet's model.

Layer: after nose_envelope (the gouge check) and before polishing and optics; it reads
the toolpath, the lathe, the tool, the stock and the [toolpath] settings, never the
config dict. shop.programs.shop_program strings it together (plan, simulate, refuse, sheet).

- program.py   the program model (Operation, blocks, Program); its knobs are the
               [toolpath] section, toolpath.ToolpathSettings
- plan.py      plan_program: the operations, checked (stock, gouge, travel) and numbered
- roughing.py  facing through X0, roughing levels (ramped pockets), semi-finish into the
               step's corner, the finishing pass's lead-in and exit, the way home
- partoff.py   the part-off: the parting blade (T5) through the axis at the CAD body's
               length plus the back's allowance, before the program's end
- second.py    the second set-up: the parted part reversed in soft jaws (their grip checked:
               toolpath.min_grip_mm and half the part's stand-out), its back faced and the
               mount (bore, boss) cut, the mount's face finished, Z0 on the back face
- boring.py    the mount's bore: the spot drill (T6), the drill the boring bar enters (T7,
               its point below the floor), the boring bar (T8) roughing and finishing
- stock.py     the stock simulation (shapely): stock minus the swept tool (each station's
               shape), per-operation removal, depth of cut, chip load, air time, cycle time
               (G96 with the spindle cap); refuses a rapid or the body touching stock, a
               part-off that leaves the part on; either set-up (simulate, simulate_setup)
- swept.py     what the tool sweeps along each piece of an operation, all at once (convex
               hulls folded at the axis, the chuck and part checks, the zone's half planes)
- tool_shapes.py  the insert (nose, flanks, cutting part), the parting blade, a drill and
               the boring bar (its insert and round shank)
- sim_results.py  what the simulation reports (moves, contacts, figures, the parted part)
- setup.py     the set-up sheet's model: work zero, stock, tools, offsets for the
               nose-centre convention, centre height, times, pictures' geometry
- replay.py    a G-code program read back into moves the simulation replays, each line
               put in the common form by its dialect (export.dialects, handed in)
- check.py     `toolpath --check`: a written program's text simulated against the set-up
               it belongs to (the second set-up's by its first operation)
- measured.py  a made part measured (`measure`: fit, diagnosis, form verdicts) and the next
               job it asks for (`compensate`: the re-cut program, its sheet, job.toml's text)
- feasible.py  whether a design not from the configuration can be made (the optimiser's)
"""

from .plan import plan_program

__all__ = ["plan_program"]
