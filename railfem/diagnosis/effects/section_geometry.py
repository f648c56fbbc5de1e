"""The rail section as built: a foot thicker or thinner than the drawing.

The base model meshes the nominal 60E1 outline. Rolled rails keep their dimensions only to
a tolerance and wear away in service, and a cross-section wave's cut-on frequency follows
the part of the section that deforms. The foot-flapping cut-on (about 5.1 kHz on 60E1:
the two halves of the foot bend as plates against the rest of the section) is the one a
vertical hammer test sees; on the WFE section its in-plane cut-on moves by about 124 Hz
per mm of foot thickness, against 26 Hz per mm of web thickness and 8 Hz per mm of head
height loss (railfem.rail.profiles.uic60_modified, tests/test_section_geometry.py), so
the foot's thickness is the parameter the data can tell (a 5 kHz misfit of a few hundred
Hz is a foot 2-3 mm off the drawing; the same shift by the web would take a web 10 mm
thicker). Enters the spec as the rail's profile (RailSpec.profile '60E1:foot=F', the
outline of uic60_modified meshed by Gmsh): a kernel parameter, profiled over a small grid
(a new mesh and kernel per value). The beam models have no cross-section (the verdict says
so); a rail that is not the 60E1 outline has no parametrised variant (apply refuses).

The model-form discrepancy (railfem.identify.discrepancy) moves the same cut-on: the
discretisation variants of the base shift it by 15-100 Hz (straight edges about +75 Hz on
the free section), which is 0.1-0.8 mm of foot. Where the two share the band, the
diagnosis reads the discrepancy in the effect's own units: the foot thickness's interval
carries the variants' shift of the estimate along the secant from the nominal foot
(railfem.diagnosis.intervals.grid_shift_variance, widen), and the held-out gate asks the
estimate to lie outside the 95 % range of that shift
(railfem.diagnosis.residual.along_discrepancy): a foot change that only absorbs another
mesh's cut-on offset is not claimed."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.rail.profiles import MODIFY_LIMITS, modified_name

#: foot thickness changes profiled (m), refined at the parabola through the best value and
#: its neighbours (each value is a mesh and a WFE kernel); the ends lie beyond rolling
#: tolerance and ordinary wear, so that a plausible foot is bracketed (a best value at an
#: end is not refined): the low end is the parameter's bound, the high end 1 mm beyond 4
#: mm, as another discretisation's cut-on reads as up to +1 mm of foot (a foot 2.5 mm
#: thicker in a straight-sided mesh: best 3.5 mm; with the grid ending at 4 mm the best
#: value was that end, unrefined, and the held-out gain 54 % instead of 82 %). Steps of 1
#: mm (about 120 Hz of cut-on): the flapping peak and the dip beside it are about 100 Hz
#: wide and ninth-octave lines lie about 400 Hz apart there, so the misfit is not a parabola
#: in the thickness over 2 mm steps (on data from another discretisation, a foot 2.5 mm
#: thicker: cost 2340 at 0, 6940 at 2 mm, 1740 at 4 mm; the best value at the grid's end);
#: over 1 mm steps it is near its minimum.
FOOT_CHANGES = (-0.004, -0.003, -0.002, -0.001, 0.0, 0.001, 0.002, 0.003, 0.004, 0.005)
NOMINAL = ("60E1", "UIC60")


def apply(spec, theta, record=None):
    if spec.rail.mesh_file is not None or spec.rail.profile.upper() not in NOMINAL:
        raise ValueError(f"section_geometry changes the 60E1 outline; the rail here is "
                         f"{spec.rail.mesh_file or spec.rail.profile!r}")
    dt = float(theta["foot_thickness"]) * 1e3
    return spec.replace(rail=replace(spec.rail, profile=modified_name(foot=round(dt, 4))))


EFFECT = Effect(
    name="section_geometry", title="rail section as built (foot thickness)", kind="spec",
    apply=apply,
    meaning="the rail's foot is thicker or thinner than the nominal 60E1 drawing (rolling "
            "tolerance, wear, corrosion): the foot-flapping cut-on (about 5 kHz) moves",
    parameters=(EffectParameter(name="foot_thickness", unit="m",
                                lower=MODIFY_LIMITS["foot"][0] * 1e-3,
                                upper=MODIFY_LIMITS["foot"][1] * 1e-3, log=False, start=0.0,
                                meaning="change of the foot's thickness from the drawing "
                                        "(every point of the foot's upper surface moved "
                                        "up; the web and head ride on it)"),),
    grid={"foot_thickness": FOOT_CHANGES}, needs=("wfe",))
