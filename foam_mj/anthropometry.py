"""Winter's anthropometric table and subject scaling of a leg model through :class:`mujoco.MjSpec`.

Source: D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Wiley, 2009,
Table 4.1 (segment mass fractions, centre-of-mass location and radii of gyration, after Dempster) and
Fig. 4.1 (segment lengths as fractions of the standing height H).

Units: lengths are fractions of the standing height H (m), masses fractions of the body mass M (kg),
centre of mass and radius of gyration fractions of the segment length (from the proximal end, and
about the centre of mass).

How a model is scaled
---------------------
A model that can be scaled declares, in ``<custom>``:

* ``<numeric name="foam_mj:subject" data="H M"/>``: the height (m) and mass (kg) it was built for;
* ``<text name="foam_mj:segments" data="body segment length ..."/>``: triples of a body name, a row
  of :data:`SEGMENTS` and the body's segment length in the model (m).

For a subject of height H' and mass M', each declared body b with segment s and model length L gets

* length factor ``k = SEGMENTS[s].length * H' / L`` (so its length becomes exactly Winter's fraction of
  H'): the positions of b's child bodies, ``<frame>`` elements, geoms (pos, fromto, size), sites (pos or
  fromto), cameras, lights, joints and centre of mass are multiplied by k (capsule radii and box half-widths
  too: girth is taken to scale with length);
* mass ``m' = m + SEGMENTS[s].mass * (M' - M)``: the human part of the segment changes by Winter's
  mass fraction, an orthosis's mass (already in m) is kept;
* inertia ``I' = I (m' / m) k^2``: the segment's inertia scaled as a rigid body of the same shape.
  An approximation where the body holds an orthosis: the mass rule keeps the orthosis's mass while the
  human part changes, so the mass is no longer distributed as before, and the exact moment (Winter's segment
  plus the brace, parallel-axis theorem) differs. For the Ortholeg's thigh and shank (2 and 1.5 kg braces,
  models/ortholeg5.xml's header) the transverse moment about the centre of mass is 2-3 % too large for a
  1.62 m, 58 kg subject, 14-15 % too large at 25 kg and 7 % too small at 200 kg (either height), and the
  centre of mass within 2 % of its exact distance from the joint.

The parent of the first declared body (the pelvis carriage) is moved so that its height above the
floor scales by H'/H, keeping the swing foot's clearance in proportion. Slide-joint ranges (the hip's
travel) are not scaled. Only primitive geoms can be scaled (a mesh geom is refused).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from foam_mj.errors import ModelError

SUBJECT_FIELD = "foam_mj:subject"
SEGMENTS_FIELD = "foam_mj:segments"


@dataclass(frozen=True)
class Segment:
    """One row of Winter's table: length / H, mass / M, centre of mass / length (from the proximal
    end), radius of gyration about the centre of mass / length."""

    length: float
    mass: float
    com: float
    gyration: float


#: Winter (2009), Table 4.1 and Fig. 4.1. Thigh: greater trochanter to femoral condyles; leg (shank):
#: femoral condyles to medial malleolus; foot: lateral malleolus to head of metatarsal II, its length the
#: heel-to-toe length of Fig. 4.1.
SEGMENTS: dict[str, Segment] = {
    "thigh": Segment(length=0.245, mass=0.100, com=0.433, gyration=0.323),
    "leg": Segment(length=0.246, mass=0.0465, com=0.433, gyration=0.302),
    "foot": Segment(length=0.152, mass=0.0145, com=0.50, gyration=0.475),
}
#: Other heights of Fig. 4.1, fractions of H: the hip (greater trochanter), the ankle (malleolus) and the foot's width.
HIP_HEIGHT = 0.530
ANKLE_HEIGHT = 0.039
FOOT_WIDTH = 0.055


def segment_length(segment: str, height: float) -> float:
    """Winter's length of ``segment`` (m) for a subject ``height`` m tall."""
    return SEGMENTS[segment].length * height


def segment_mass(segment: str, mass: float) -> float:
    """Winter's mass of ``segment`` (kg) for a subject of ``mass`` kg."""
    return SEGMENTS[segment].mass * mass


def segment_inertia(segment: str, height: float, mass: float) -> float:
    """Winter's moment of inertia (kg m^2) of ``segment`` about a transverse axis through its centre of mass."""
    s = SEGMENTS[segment]
    return s.mass * mass * (s.gyration * s.length * height) ** 2


def _custom(spec: mujoco.MjSpec, scene: Path) -> tuple[float, float, list[tuple[str, str, float]]]:
    subject = next((n for n in spec.numerics if n.name == SUBJECT_FIELD), None)
    segments = next((t for t in spec.texts if t.name == SEGMENTS_FIELD), None)
    if subject is None or segments is None:
        raise ModelError(
            f"{scene}: subject scaling needs the model to declare '{SUBJECT_FIELD}' (height mass) and "
            f"'{SEGMENTS_FIELD}' (body segment length ...) in <custom> (see foam_mj/anthropometry.py)"
        )
    data = list(subject.data)
    if len(data) != 2 or not (data[0] > 0 and data[1] > 0):
        raise ModelError(f"{scene}: '{SUBJECT_FIELD}' must hold the model's subject height (m) and mass (kg)")
    words = segments.data.split()
    if not words or len(words) % 3:
        raise ModelError(f"{scene}: '{SEGMENTS_FIELD}' must hold triples 'body segment length'")
    rows: list[tuple[str, str, float]] = []
    for i in range(0, len(words), 3):
        body, seg, word = words[i], words[i + 1], words[i + 2]
        if seg not in SEGMENTS:
            raise ModelError(f"{scene}: '{SEGMENTS_FIELD}': unknown segment '{seg}'; known: {sorted(SEGMENTS)}")
        try:
            length = float(word)
        except ValueError:
            length = float("nan")
        if not (np.isfinite(length) and length > 0):
            raise ModelError(f"{scene}: '{SEGMENTS_FIELD}': the length of body '{body}' must be a positive number of metres, got '{word}'")
        if body in (r[0] for r in rows):
            raise ModelError(f"{scene}: '{SEGMENTS_FIELD}' names body '{body}' twice; each body is one segment")
        rows.append((body, seg, length))
    return float(data[0]), float(data[1]), rows


def model_subject(spec: mujoco.MjSpec, scene: Path) -> tuple[float, float]:
    """The height (m) and mass (kg) the model declares it was built for."""
    h, m, _ = _custom(spec, scene)
    return h, m


def scale_to_subject(spec: mujoco.MjSpec, scene: Path, height: float | None, mass: float | None) -> None:
    """Scale the declared leg segments of ``spec`` in place to a subject (module docstring).

    ``height`` (m) or ``mass`` (kg) None keeps the model's.
    """
    h0, m0, rows = _custom(spec, scene)
    h = h0 if height is None else float(height)
    m = m0 if mass is None else float(mass)
    first = None
    for body_name, seg, length in rows:
        body = spec.body(body_name)
        if body is None:
            raise ModelError(f"{scene}: '{SEGMENTS_FIELD}' names body '{body_name}', which is not in the model")
        if body_name == "world":
            raise ModelError(f"{scene}: '{SEGMENTS_FIELD}' names the world body '{body_name}'; name the leg's moving bodies")
        first = first or body
        k = SEGMENTS[seg].length * h / length
        for child in body.bodies:
            child.pos = np.asarray(child.pos) * k
        for frame in body.frames:  # every <frame> of the body, nested ones too: what they place moves with them
            frame.pos = np.asarray(frame.pos) * k
        for g in body.geoms:
            if g.type in (mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_SDF, mujoco.mjtGeom.mjGEOM_HFIELD):
                raise ModelError(f"{scene}: subject scaling supports primitive geoms only; geom '{g.name}' of body '{body_name}' is not")
            g.pos = np.asarray(g.pos) * k
            if not np.any(np.isnan(g.fromto)):
                g.fromto = np.asarray(g.fromto) * k
            g.size = np.asarray(g.size) * k
        for site in body.sites:
            site.pos = np.asarray(site.pos) * k
            if not np.any(np.isnan(site.fromto)):
                site.fromto = np.asarray(site.fromto) * k
            site.size = np.asarray(site.size) * k
        for placed in (*body.cameras, *body.lights):
            placed.pos = np.asarray(placed.pos) * k
        for j in body.joints:
            j.pos = np.asarray(j.pos) * k
        if not body.explicitinertial and body.mass == 0:
            raise ModelError(f"{scene}: subject scaling needs an explicit <inertial> on body '{body_name}'")
        old_mass = float(body.mass)
        new_mass = old_mass + SEGMENTS[seg].mass * (m - m0)
        if not new_mass > 0:
            raise ModelError(f"{scene}: subject mass {m} kg leaves body '{body_name}' with no mass")
        body.ipos = np.asarray(body.ipos) * k
        body.inertia = np.asarray(body.inertia) * (new_mass / old_mass) * k**2
        if not np.any(np.isnan(body.fullinertia)):
            body.fullinertia = np.asarray(body.fullinertia) * (new_mass / old_mass) * k**2
        body.mass = new_mass
    root = first.parent if first is not None else None
    if root is not None and root.name != "world":
        root.pos = np.asarray(root.pos) * np.array([1.0, 1.0, h / h0])
    for n in spec.numerics:
        if n.name == SUBJECT_FIELD:
            n.data = [h, m]
    for t in spec.texts:
        if t.name == SEGMENTS_FIELD:
            t.data = " ".join(f"{b} {s} {SEGMENTS[s].length * h:.6g}" for b, s, _ in rows)
