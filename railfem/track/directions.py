"""The support in every direction: the pad - sleeper - ballast chain per direction and the
fastening's grip on the rail foot.

A support (railfem.track.supports.SupportParameters) acts on the rail foot vertically
(u_z: the published pad - sleeper - ballast chain, METHOD.md section 2) and, where the
track's ``support_directions`` ask for it (railfem.spec.TrackSpec), laterally (u_y),
longitudinally (u_x) and in roll (the foot's rotation about the rail axis, 'r'). Each
direction is the same series chain in vertical form (``chain``): the pad (with the clips
laterally, the roll restraint in roll) between rail and sleeper, the sleeper's mass, its
support in the ballast. ``directional_stiffness`` is its dynamic stiffness,
``acts_in`` whether the support restrains a direction at all.

The vertical pad springs across the foot meet the sleeper at one rail seat
(SupportParameters.seat 'rigid', the default; docs/supports.md): the seat translates with the
sleeper, so the springs' common vertical motion sees the whole chain ('z'), but on the rigid
sleeper of a symmetric track it does not turn about the rail axis, so the springs' antisymmetric
part, the foot's roll against the seat, sees the pad alone (PAD_ROLL, 'z-'). seat
'per_spring' keeps the published form: every spring its own chain in both ('z-' = 'z').

Conventions (railfem.conventions): exp(+i omega t); SI units (N/m, N m/rad, kg, rad/s).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from .sleeper import Sleeper

if TYPE_CHECKING:
    from .supports import SupportParameters

#: The horizontal fields of SupportParameters (additive to the vertical ones).
HORIZONTAL_STIFFNESS = ("kp_lat", "kp_long", "kb_lat")
HORIZONTAL_LOSS = ("eta_p_lat", "eta_p_long", "eta_b_lat")
HORIZONTAL_SCALED = ("kp_lat", "kp_long", "kb_lat", "ms_lat")
HORIZONTAL_FIELDS = ("kp_lat", "eta_p_lat", "kp_long", "eta_p_long", "kb_lat", "eta_b_lat",
                     "ms_lat")
#: The fastening's grip on the rail foot (roll and clip, additive to the others).
GRIP_FIELDS = ("k_roll", "eta_roll", "k_clip", "eta_clip")
GRIP_SCALED = ("k_roll", "k_clip")
#: Directions a support acts in: u_z (vertical), u_y (lateral), u_x (longitudinal).
DIRECTIONS = ("z", "y", "x")
#: The roll of the foot (a rotation about the rail axis, rad): the grip's generalised spring.
ROLL = "r"
#: The vertical pad springs acting antisymmetrically across the foot (mirror-pair
#: differences): the pad between the rolling foot and the rail seat (module docstring).
PAD_ROLL = "z-"


def chain(params: SupportParameters, direction: str = "z") -> SupportParameters:
    """The pad - sleeper - ballast chain acting in ``direction`` as vertical-form
    SupportParameters (kp, eta_p, ms, kb, eta_b): 'z' is params itself; 'y' the lateral pad
    on the sleeper's horizontal ballast support (with the clips k_clip in parallel with the
    pad); 'x' the longitudinal pad on the same; 'z-' (PAD_ROLL) the vertical pad springs
    against the foot's roll (``seat_roll_chain``); 'r' the roll restraint k_roll (N m/rad) on
    the sleeper's roll: rigid while the ballast holds the sleeper (assumed: the whole
    sleeper's rocking on it, 2 kb (L^2 / 12 + g^2 / 4) about a rail seat, is ~240 times
    a grip of 4e5 N m/rad on the site ballast), its rotational inertia alone
    (``roll_inertia``) once the sleeper hangs (kb = 0: voided). Any kb > 0 counts as
    holding: a ballast factor of 1e-3 keeps the rigid roll (a finite rocking stiffness
    would change the intact track's roll chain by ~0.3 % at 4e5 N m/rad)."""
    if direction == "z":
        return params
    if direction == PAD_ROLL:
        return seat_roll_chain(params)
    if direction == ROLL:
        if params.kb > 0:
            return type(params)(kp=params.k_roll, eta_p=params.eta_roll, ms=0.0, kb=math.inf)
        return type(params)(kp=params.k_roll, eta_p=params.eta_roll,
                            ms=roll_inertia(params), kb=0.0)
    if direction not in DIRECTIONS:
        raise ValueError(f"support direction {direction!r}: use one of {', '.join(DIRECTIONS)}"
                         f", {ROLL!r} (roll) or {PAD_ROLL!r} (the pad against the foot's roll)")
    kp, eta = ((params.kp_lat, params.eta_p_lat) if direction == "y"
               else (params.kp_long, params.eta_p_long))
    if direction == "y" and params.k_clip > 0:  # pad and clips in parallel
        kp = params.kp_lat + params.k_clip
        eta = 0.0 if math.isinf(kp) else (params.kp_lat * params.eta_p_lat
                                          + params.k_clip * params.eta_clip) / kp
    return type(params)(kp=kp, eta_p=eta, ms=params.ms_lat, kb=params.kb_lat,
                        eta_b=params.eta_b_lat)


def seat_roll_chain(params: SupportParameters) -> SupportParameters:
    """The vertical pad springs' chain against the foot's roll (PAD_ROLL), vertical form.

    seat 'rigid': the pad alone (its frequency laws kept), the seat held: a spring pair at
    +-y compressed in opposite senses turns the seat, and the rigid sleeper of a symmetric
    track does not turn about the rail axis (the other rail holds it; docs/supports.md).
    Held in this model, though a real seat turns a little: with two rails and a rigid
    sleeper it rocks against ~ (kb* - omega^2 ms) L^2 / 12 per rail (120 kg, 2.6 m, site
    ballast: 22 times the 600 MN/m pad's 1.07e6 N m/rad at 100 Hz, 220 times at 315 Hz);
    hanging (kb = 0) it turns against its inertia alone (held above ~20 Hz);
    a flexible sleeper's slope at the seat is left out. seat 'per_spring': the published
    chain, each spring with its share of the sleeper mass (the seat rolls with the foot)."""
    if params.seat == "per_spring" or (params.kb == 0 and params.ms == 0 and params.mb == 0):
        return params  # (nothing holds a massless hanging seat: the chain's own 0)
    return replace(params, ms=0.0, kb=math.inf, eta_b=0.0, mb=0.0, kf=math.inf, eta_f=0.0,
                   absorber=None, sleeper=None, case="symmetric")


def family_direction(direction: str, family: str) -> str:
    """The chain of a continuous support's ``direction`` bed on the rail's wave ``family``:
    the vertical bed on the antisymmetric family (the foot's roll) is PAD_ROLL."""
    return PAD_ROLL if direction == "z" and family == "antisymmetric" else direction


def roll_inertia(params: SupportParameters) -> float:
    """A rail's share (kg m^2) of the rotational inertia of a hanging sleeper about an axis
    parallel to the rails: a free rigid body turns about its centre of mass under a
    moment, so half the uniform sleeper's J = 2 ms L^2 / 12 (the rocking inertia of
    railfem.track.sleeper), ms L^2 / 12 with ms per rail (half a flexible sleeper's mass)
    and L of ``params.sleeper`` or of the default sleeper (2.6 m: 0.563 m^2 times ms).
    Left out, as in the vertical chain of a single rail: the seat's vertical motion that
    comes with the rotation and the other rail's hold on the sleeper."""
    sl = params.sleeper if params.sleeper is not None else Sleeper(model="rigid")
    mass = sl.mass / 2 if sl.model == "flexible" else params.ms
    return mass * sl.length ** 2 / 12


def directional_stiffness(params: SupportParameters, omega, direction: str = "z"):
    """Dynamic stiffness (N/m, complex, shape of omega) of one support in ``direction``
    ('z', 'y', 'x' or 'z-' (PAD_ROLL); N m/rad for the roll 'r'): ``dynamic_stiffness`` of
    ``chain(params, direction)``."""
    from .supports import dynamic_stiffness  # here: supports builds its layouts on this module

    return dynamic_stiffness(chain(params, direction), omega)


def acts_in(params: SupportParameters, direction: str) -> bool:
    """Whether the support has a pad in ``direction`` (the vertical ones, 'z' and 'z-',
    always count; 'y' with the clips, 'r' the roll restraint)."""
    if direction == PAD_ROLL:
        return True
    if direction == ROLL:
        return params.k_roll > 0
    return direction == "z" or (params.kp_lat + params.k_clip if direction == "y"
                                else params.kp_long) > 0


__all__ = ["HORIZONTAL_STIFFNESS", "HORIZONTAL_LOSS", "HORIZONTAL_SCALED", "HORIZONTAL_FIELDS",
           "GRIP_FIELDS", "GRIP_SCALED", "DIRECTIONS", "ROLL", "PAD_ROLL", "chain",
           "directional_stiffness", "acts_in", "roll_inertia", "seat_roll_chain",
           "family_direction"]
