"""Foot-pad gains and offsets estimated together with the mass model, from several sessions.

Modules: ``model`` (inputs, options and results), ``rows`` (the linear system), ``solve``
(``calibrate_sensors``: noise levels and the prior scale by iteration), ``directions`` (the
sensor directions the sessions leave undetermined, named), ``sessions`` (raw logs → sessions,
and the calibrated sensor file).

Sensor model. Each pad k of a foot reads ``y_k = F_k / g_k + o_k`` (N): a gain ``g_k`` and an
offset ``o_k`` (the offset of a session: FSR offsets drift from day to day, so every session
has its own; the gains belong to a sensor set, shared by the sessions that use it). A pad's
force is then ``F_k = g_k y_k − β_k`` with ``β_k = g_k o_k``: linear in ``(g, β)``.

Statics. Four pads under a foot and three equations of statics: the split of the load over the
pads is statically indeterminate (it depends on the foot's stiffness), so the model uses only
what statics determines per pose — the total normal force and the two moments about the ground
frame's axes (equivalently the CoP) of all loaded pads together:

    Σ_k (g_k y_k − β_k)                = W (−g_z)
    Σ_k (g_k y_k − β_k) p_k / W        = T (R_Gᵀ (d + Φ(q) vec(r) − o_G))

with ``W`` the robot's weight (its weighed mass × g: it fixes the scale of the gains), ``p_k``
the pad's position in the ground frame G (the sole frame of a loaded foot; in double support
both soles are on the ground plane), ``T = [I₂, −g_xy/g_z]`` the projection along gravity ``g``
(unit, in G; ``(0, 0, −1)`` for a level sole) and ``Φ`` the full 3-row regressor of the robot
rooted at its support frame. Everything is linear in ``θ = (vec(r), g, β)``: one least-squares
problem, solved with Gaussian priors (the CAD SESC vectors with scale τ chosen by the evidence
as in ``map``; gains ``N(1, gain_prior²)``; offsets ``N(0, offset_prior²)``), so directions the
data cannot see come from the priors and are named.

What the pads cannot tell (``SensorDirection.kind``):

- ``unloaded-foot``: a foot that never carries load in any session of a sensor set leaves its
  gains unseen (and a session's offsets of a foot it never loads);
- ``offset-twist``: per session and foot, the offset combination orthogonal to (1, p_x, p_y)
  over the 4 pads changes neither the total force nor the moments: statics never sees it;
- ``support-confounded``: with one foot only, the offsets' moments add a constant CoP shift in
  that foot's frame, exactly as the SESC components of the body fixed to that sole do — poses on
  the other foot separate them;
- ``scale``: without a weighed mass the weight is the model's, an assumption, not a measurement;
- ``not-excited``: the gains are told apart only because the pads' load pattern varies beyond
  what the CoP fixes (the statically indeterminate part of the split changes from pose to pose,
  as a real foot's compliance makes it); a split that is linear in the CoP (a rigid plate on
  equal springs) leaves one gain direction per foot unseen.

Noise. Each session has its own noise level on the force rows (N) and on the moment rows (m,
which also take up joint play and other model error), estimated by iterating
``σ² = RSS / (rows − leverage)`` per session and row type (or given), alternating with τ.
Each session's contribution is its share of the total leverage (effective parameters).

Pad positions are not unknowns: a pad position enters the moment rows multiplied by its force,
and a shift of all four pads is a constant CoP shift again (confounded exactly like the
offsets), while the spacing trades against the gains; without a measured prior on them they are
poorly determined, so they stay a given of the sensor file (measure them).
"""

from sescid.sensors.calibration.model import (
    GAIN_PRIOR,
    OFFSET_PRIOR,
    CalibrationOptions,
    KnownSensors,
    PadFoot,
    PadSession,
    SensorCalibration,
    SensorDirection,
    SensorParameter,
    SessionContribution,
)
from sescid.sensors.calibration.sessions import (
    PadSessionOptions,
    calibrated_sensor_document,
    pad_session,
)
from sescid.sensors.calibration.solve import calibrate_sensors

__all__ = [
    "GAIN_PRIOR",
    "OFFSET_PRIOR",
    "CalibrationOptions",
    "KnownSensors",
    "PadFoot",
    "PadSession",
    "PadSessionOptions",
    "SensorCalibration",
    "SensorDirection",
    "SensorParameter",
    "SessionContribution",
    "calibrate_sensors",
    "calibrated_sensor_document",
    "pad_session",
]
