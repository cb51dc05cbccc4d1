"""The configuration map: the planner's coordinates q and MuJoCo's qpos.

The configuration coordinates are, in order of precedence: the joint names a scenario gives
(``joints = [...]``, passed here as ``joints``), the MJCF's ``<custom>`` text field
``foam_mj:configuration`` (joint names, in order), or else every *limited* hinge and slide joint in
model order (unlimited hinges, ball and free joints then stay at ``qpos0``). A configuration joint
must be a limited hinge or slide: a ball or free joint, an unlimited joint, or the name of a tendon is
refused with a :class:`~foam_mj.errors.ModelError` naming it, before any planning. A coordinate is the joint's own value
(radians for hinges, metres for slides) unless a numeric field ``foam_mj:normalize:<joint>`` holds
"a b S", in which case qpos values a..b map linearly onto [0, S] (one number S alone means the joint's
range [lo, hi]):

    q_i = S (qpos_j - a) / (b - a)        qpos_j = a + (b - a) q_i / S.

For the Ortholeg, q = [theta_h, theta_k, theta_q] with theta_q the hip displacement normalized so that
the swing's 0.7 m of travel is [0, pi/2] (Nascimento and Alsina 2021, section 5.1). Joints that are not configuration coordinates stay at their
``qpos0``. The bounds of q come from the joint ranges (every configuration joint must be limited).
A scenario's ``[normalize]`` table gives the same numbers per joint and takes precedence over the MJCF.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from foam_mj.errors import ConfigurationError, ModelError, unknown_names
from foam_mj.mjcf import _custom_numeric, _custom_text

CONFIGURATION_FIELD = "foam_mj:configuration"
NORMALIZE_PREFIX = "foam_mj:normalize:"

#: MuJoCo's joint type numbers of a hinge and a slide, the joints foam-mj plans over (one definition for the package).
HINGE, SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
_SUPPORTED_JOINTS = (HINGE, SLIDE)


@dataclass(frozen=True)
class ConfigurationMap:
    """Affine map between the planner's q (n,) and MuJoCo's qpos (nq,): qpos[index] = offset + scale * q."""

    joint_names: tuple[str, ...]
    joint_ids: np.ndarray  # (n,) joint ids
    qpos_index: np.ndarray  # (n,) qpos addresses
    scale: np.ndarray  # (n,) qpos units per q unit
    offset: np.ndarray  # (n,)
    lower: np.ndarray  # (n,) bounds of q
    upper: np.ndarray  # (n,)
    qpos0: np.ndarray  # (nq,) values of the joints that are not coordinates

    @property
    def dim(self) -> int:
        return len(self.joint_names)

    def to_qpos(self, q: np.ndarray) -> np.ndarray:
        """qpos rows for configurations q of shape (n,) or (N, n)."""
        q = np.asarray(q, dtype=float)
        if q.ndim == 0 or q.shape[-1] != self.dim:
            raise ConfigurationError(self._shape_text("to_qpos", "configurations q", self.dim, q.shape, "to_q"))
        out = np.broadcast_to(self.qpos0, q.shape[:-1] + self.qpos0.shape).copy()
        out[..., self.qpos_index] = self.offset + self.scale * q
        return out

    def to_q(self, qpos: np.ndarray) -> np.ndarray:
        """Configurations for qpos rows of shape (nq,) or (N, nq)."""
        qpos = np.asarray(qpos, dtype=float)
        if qpos.ndim == 0 or qpos.shape[-1] != self.qpos0.size:
            raise ConfigurationError(self._shape_text("to_q", "qpos rows", self.qpos0.size, qpos.shape, "to_qpos"))
        return (qpos[..., self.qpos_index] - self.offset) / self.scale

    def _shape_text(self, method: str, what: str, width: int, shape: tuple[int, ...], other: str) -> str:
        """A wrong-width argument of ``method`` named, and, when it has the other side's width, which method takes it
        (numpy's "operands could not be broadcast" or "index 7 is out of bounds" named neither)."""
        n, nq = self.dim, self.qpos0.size
        text = (f"{method} takes {what} of shape ({width},) or (N, {width}) (n = {n} configuration joints: "
                f"{', '.join(self.joint_names)}; nq = {nq} qpos entries), got shape {shape}")
        if shape and shape[-1] == (nq if width == n else n):
            text += f": {'qpos' if width == n else 'q'}'s width; {other}() maps that one"
        return text


_JOINT_TYPE_NAMES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "a free joint",
    int(mujoco.mjtJoint.mjJNT_BALL): "a ball joint",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "a slide joint",
    int(mujoco.mjtJoint.mjJNT_HINGE): "a hinge joint",
}


def _joint_name(m: mujoco.MjModel, j: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"


def configuration_joint_names(m: mujoco.MjModel, path: str | Path, joints: Sequence[str] | None = None) -> list[str]:
    """The configuration joints' names (module docstring: scenario, MJCF declaration, or every limited
    hinge/slide joint)."""
    if joints is not None:
        return list(joints)
    text = _custom_text(m, CONFIGURATION_FIELD)
    if text is not None:
        return text.split()
    ids = [j for j in range(m.njnt) if int(m.jnt_type[j]) in _SUPPORTED_JOINTS and m.jnt_limited[j]]
    unnamed = [j for j in ids if not mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)]
    if unnamed:
        raise ModelError(
            f"{path}: joint {unnamed[0]} (a limited hinge/slide, so a configuration joint by default) has no name; "
            "name it in the MJCF or list the configuration joints with `joints = [...]` (--joints)"
        )
    if not ids:
        raise ModelError(f"{path}: the model has no limited hinge or slide joint to plan over (give joints a range)")
    return [_joint_name(m, j) for j in ids]


def check_configuration_joint(m: mujoco.MjModel, path: str | Path, name: str) -> int:
    """The id of joint ``name`` if it can be a configuration coordinate; ModelError saying why not otherwise."""
    j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
    if j < 0:
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, name) >= 0:
            raise ModelError(
                f"{path}: configuration joint '{name}' is a tendon, not a joint; foam-mj plans over hinge and slide joints"
            )
        known = [_joint_name(m, k) for k in range(m.njnt)]
        raise ModelError(f"{path}: configuration joint {unknown_names([name], known)} is not in the model (joints: {known})")
    kind = int(m.jnt_type[j])
    if kind not in _SUPPORTED_JOINTS:
        raise ModelError(
            f"{path}: configuration joint '{name}' is {_JOINT_TYPE_NAMES.get(kind, 'not a hinge or slide')}; "
            "foam-mj plans over hinge and slide joints only (leave it out of the configuration)"
        )
    if not m.jnt_limited[j]:
        lo, hi = (float(v) for v in m.jnt_range[j])
        if hi > lo:  # a range MuJoCo ignores: limited="false" on the joint or its default class
            raise ModelError(
                f"{path}: configuration joint '{name}' has range=\"{lo:g} {hi:g}\" but limited=\"false\" (on the joint or its "
                "default class), so MuJoCo ignores that range; the bounds of q come from it (set limited=\"true\", or leave "
                "the joint out of the configuration)"
            )
        raise ModelError(
            f"{path}: configuration joint '{name}' has no range; the bounds of q come from it "
            "(add range=\"lo hi\" to the joint, or leave it out of the configuration)"
        )
    return j


def checked_normalize(normalize) -> dict[str, list[float]] | None:
    """``normalize`` as given to :meth:`foam_mj.model.RobotModel.from_spec` (joint name -> span, or [span], or [qpos_lo,
    qpos_hi, span]) as a dict of float lists; TypeError naming the entry otherwise (a word was numpy's "could not convert
    string to float", True a span of 1). The values themselves are checked with the joint's range (:func:`_configuration_map`)."""
    if normalize is None:
        return None
    if not isinstance(normalize, Mapping):
        raise TypeError(f"`normalize` must be a mapping joint name -> span or [qpos_lo, qpos_hi, span], got {type(normalize).__name__}")
    out: dict[str, list[float]] = {}
    for name, value in normalize.items():
        if not isinstance(name, str):
            raise TypeError(f"`normalize` keys must be joint names (strings), got {name!r}")
        values = [value] if np.ndim(value) == 0 and not isinstance(value, str) else value
        if isinstance(values, str) or not all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
                                               for v in values):
            raise TypeError(f"`normalize[{name!r}]` must be a number (span) or 3 numbers (qpos_lo, qpos_hi, span), got {value!r}")
        out[name] = [float(v) for v in values]
    return out


def _configuration_map(
    m: mujoco.MjModel,
    path: Path,
    joints: Sequence[str] | None = None,
    normalize: Mapping[str, Sequence[float]] | None = None,
) -> ConfigurationMap:
    names = configuration_joint_names(m, path, joints)
    if not names:
        raise ModelError(f"{path}: the configuration declares no joints")
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ModelError(f"{path}: configuration joint(s) {dup} listed more than once")
    normalize = dict(normalize or {})
    joint_names = {_joint_name(m, k) for k in range(m.njnt)}
    declared = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_NUMERIC, i) or "" for i in range(m.nnumeric)]
    typos = sorted(n[len(NORMALIZE_PREFIX):] for n in declared
                   if n.startswith(NORMALIZE_PREFIX) and n[len(NORMALIZE_PREFIX):] not in joint_names)
    if typos:  # a [normalize] entry (or an MJCF field) for a joint the model does not have would be ignored
        raise ModelError(f"{path}: normalization given for {unknown_names(typos, joint_names)}, which are not joints of the model "
                         f"{sorted(joint_names)}")
    unknown = set(normalize) - set(names)
    if unknown:
        raise ModelError(f"{path}: normalization given for {sorted(unknown)}, which are not configuration joints {names}")
    ids, adr, scale, offset, lo, hi = [], [], [], [], [], []
    for name in names:
        j = check_configuration_joint(m, path, name)
        jlo, jhi = (float(v) for v in m.jnt_range[j])
        norm: np.ndarray | None
        if name in normalize:
            norm, where = np.asarray(normalize[name], dtype=float).ravel(), f"normalize.{name}"
        else:
            norm, where = _custom_numeric(m, NORMALIZE_PREFIX + name), f"'{NORMALIZE_PREFIX + name}'"
        if norm is None:
            s, o = 1.0, 0.0
        else:
            if norm.size == 1:
                a, b, span = jlo, jhi, float(norm[0])
            elif norm.size == 3:
                a, b, span = (float(v) for v in norm)
            else:
                raise ModelError(f"{path}: {where} must hold 1 number (span) or 3 (qpos_lo qpos_hi span)")
            if not (np.all(np.isfinite(norm)) and span > 0 and b > a and (b - a) / span > 0):  # an infinite span divided by 0
                raise ModelError(f"{path}: {where} needs finite numbers, span > 0 and qpos_hi > qpos_lo "
                                 f"(qpos_hi - qpos_lo over span > 0), got {norm.tolist()}")
            if not 1e-9 <= span / (b - a) <= 1e9:  # q in units of 1e-300 qpos: the bubbles' radii overflowed (NaN warnings)
                raise ModelError(f"{path}: {where} maps qpos {a:g}..{b:g} onto [0, {span:g}], {span / (b - a):.3g} q per qpos unit: "
                                 "the span must be within 1e-9..1e9 times qpos_hi - qpos_lo")
            hinge = int(m.jnt_type[j]) == HINGE
            turn = max(2 * np.pi, abs(jlo), abs(jhi))
            if hinge and norm.size == 3 and max(abs(a), abs(b)) > turn:  # beyond a turn and the range: degrees
                raise ModelError(
                    f"{path}: {where} maps qpos {a:g}..{b:g} onto [0, {span:g}], but a hinge's qpos is in radians (its range "
                    f"is [{jlo:.6g}, {jhi:.6g}], whatever the MJCF's <compiler angle>): {a:g}..{b:g} degrees is "
                    f"{np.radians(a):.6g}..{np.radians(b):.6g} radians"
                )
            s, o = (b - a) / span, a
        ids.append(j)
        adr.append(int(m.jnt_qposadr[j]))
        scale.append(s)
        offset.append(o)
        lo.append((jlo - o) / s)
        hi.append((jhi - o) / s)
    return ConfigurationMap(
        tuple(names),
        np.array(ids),
        np.array(adr),
        np.array(scale),
        np.array(offset),
        np.array(lo),
        np.array(hi),
        np.array(m.qpos0),
    )


def degrees_hint(m: mujoco.MjModel, config: ConfigurationMap, i: int, value: float) -> str:
    """Why a hinge coordinate's value is outside its bounds, when the cause is likely MJCF's degrees ("" otherwise):

    - the MJCF's range was written in radians but compiled as degrees (MuJoCo's default ``<compiler angle>``): the
      range's numbers read as degrees all lie within a turn (a range of [-3, 3] degrees is rarely meant) and the value
      lies within those numbers, so a user who meant radians is told to add ``<compiler angle="radian"/>``;
    - the value was given in degrees: within the bounds read as degrees, and more than half a turn outside them (not a
      radian value just past a limit), so the user is told that q is in radians whatever ``<compiler angle>``."""
    if int(m.jnt_type[int(config.joint_ids[i])]) != int(mujoco.mjtJoint.mjJNT_HINGE) or config.scale[i] != 1.0 or config.offset[i] != 0.0:
        return ""
    lo, hi = float(config.lower[i]), float(config.upper[i])
    lo_deg, hi_deg = np.degrees(lo), np.degrees(hi)
    if max(abs(lo_deg), abs(hi_deg)) <= 2 * np.pi * (1 + 1e-9) and lo_deg <= value <= hi_deg:
        return (f" radians (the MJCF's range of hinge {config.joint_names[i]} is [{lo_deg:.6g}, {hi_deg:.6g}], compiled as "
                "degrees: MJCF angles are degrees unless <compiler angle=\"radian\"/>; if the range is meant in radians, add "
                "<compiler angle=\"radian\"/> to the MJCF)")
    if lo <= np.radians(value) <= hi and not lo - np.pi <= value <= hi + np.pi:
        return (f" radians (hinge angles are radians whatever the MJCF's <compiler angle>, whose degrees MuJoCo converts: "
                f"{value:.6g} degrees is {np.radians(value):.6g})")
    return ""


def small_hinge_ranges_note(m: mujoco.MjModel, config: ConfigurationMap) -> str:
    """A note when every configuration hinge's range, read in degrees, lies within a turn ([-3, 3] degrees: +-0.052
    rad), as an MJCF whose ranges were written in radians compiles without ``<compiler angle="radian"/>``: such a
    plan succeeds between end points inside those few degrees and says nothing of it ("" otherwise, or without
    hinges). Ranges meant in degrees that small are rare; the note is worded for both."""
    hinges = [i for i, j in enumerate(config.joint_ids) if int(m.jnt_type[int(j)]) == int(mujoco.mjtJoint.mjJNT_HINGE)]
    ranges = np.degrees(m.jnt_range[np.asarray(config.joint_ids, dtype=int)[hinges]]) if hinges else np.empty((0, 2))
    if not hinges or np.abs(ranges).max() > 2 * np.pi * (1 + 1e-9):
        return ""
    listed = ", ".join(f"{config.joint_names[i]} [{lo:.4g}, {hi:.4g}]" for i, (lo, hi) in zip(hinges, ranges))
    return (f"note: every hinge range spans only a few degrees ({listed} degrees): MJCF reads angles in degrees unless "
            "<compiler angle=\"radian\"/>; if these ranges are meant in radians, add it to the MJCF")


#: :func:`short_slide_hint`: a configuration slide whose span in q is below this share of the widest hinge's.
SHORT_SLIDE_SHARE = 0.01


def short_slide_hint(m: mujoco.MjModel, config: ConfigurationMap) -> str:
    """What to add to a failed plan's message when a configuration slide spans less than :data:`SHORT_SLIDE_SHARE` of
    the widest configuration hinge's span in q (a 4 mm slide beside a hinge of 5.9 rad: a small robot drawn in
    metres): q mixes metres and radians, and a bubble reaches no farther than the nearest joint bound, so the search
    crawls in steps of a few mm of q along every joint (bubbletree failed after 60 s and 45,260 bubbles where the slide
    mapped onto [0, 1] planned in 585). "" when no slide is that short, or without hinges."""
    span = np.asarray(config.upper, float) - np.asarray(config.lower, float)
    kinds = np.array([int(m.jnt_type[int(j)]) for j in config.joint_ids])
    hinges, slides = kinds == int(mujoco.mjtJoint.mjJNT_HINGE), kinds == int(mujoco.mjtJoint.mjJNT_SLIDE)
    if not hinges.any() or not slides.any():
        return ""
    widest = float(span[hinges].max())
    short = [i for i in np.flatnonzero(slides) if span[i] < SHORT_SLIDE_SHARE * widest]
    if not short:
        return ""
    i = int(short[0])
    name = config.joint_names[i]
    return (f"; slide '{name}' spans only {span[i]:.3g} (metres of q) beside a hinge of {widest:.3g} rad: a bubble reaches no "
            "farther than the nearest joint bound, so the search crawls in steps smaller than that span along every joint; map "
            f"the slide onto a longer one (<numeric name=\"foam_mj:normalize:{name}\" data=\"1\"/> in the MJCF's <custom>, "
            "[normalize] in a scenario)")
