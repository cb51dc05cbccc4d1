"""The robot model: an MJCF scene, its configuration map q <-> qpos, and which geoms are robot and obstacle.

Configuration map
-----------------
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

Unnamed geoms get the name ``geom<i>`` (``i`` their index in the model) when the model is loaded, so
that the distance sensors of :mod:`foam_mj.clearance` can refer to them; an existing name is never changed.

Robot and obstacle geoms
------------------------
A collision geom (``contype`` or ``conaffinity`` non-zero) is a *robot* geom when its body is moved by
some joint (the body or one of its ancestors has a joint), and an *obstacle* geom otherwise. The
clearance pairs are every robot/obstacle pair that MuJoCo's contype/conaffinity filter lets collide.
This is the same rule the independent checker ``foam-mj verify`` (foam_mj/verify.py) uses.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from foam_mj.errors import ConfigurationError, ModelError

CONFIGURATION_FIELD = "foam_mj:configuration"
NORMALIZE_PREFIX = "foam_mj:normalize:"

_SUPPORTED_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def load_mjcf(path: str | Path) -> mujoco.MjModel:
    """Compile an MJCF file, turning MuJoCo's errors into a :class:`ModelError` naming the file."""
    return compile_spec(load_spec(path), path)


def load_spec(path: str | Path) -> mujoco.MjSpec:
    """Parse an MJCF file into a :class:`mujoco.MjSpec` (errors as :class:`ModelError` naming the file)."""
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"MJCF file not found: {p}")
    try:
        return mujoco.MjSpec.from_file(str(p))
    except ValueError as exc:  # MuJoCo reports XML and compile errors as ValueError
        raise ModelError(f"could not load MJCF file {p}: {' '.join(str(exc).split())}") from None


def compile_spec(spec: mujoco.MjSpec, path: str | Path) -> mujoco.MjModel:
    """Compile a spec, turning MuJoCo's errors into a :class:`ModelError` naming ``path``."""
    try:
        return spec.compile()
    except ValueError as exc:
        raise ModelError(f"could not load MJCF file {path}: {exc}") from None


def name_unnamed_geoms(spec: mujoco.MjSpec) -> int:
    """Give every unnamed geom of ``spec`` the name ``geom<i>`` (i: its index in the compiled model).

    MuJoCo's distance sensors refer to geoms by name; users' models often leave them unnamed. Returns
    how many geoms were named. A name already taken gets a ``_`` suffix until it is free.
    """
    geoms = list(spec.geoms)
    if all(g.name for g in geoms):
        return 0
    spec.compile()  # assigns the ids (g.id) the compiled model will use
    taken = {g.name for g in geoms if g.name}
    count = 0
    for g in geoms:
        if g.name:
            continue
        name = f"geom{int(g.id)}"
        while name in taken:
            name += "_"
        g.name = name
        taken.add(name)
        count += 1
    return count


def _custom_text(m: mujoco.MjModel, name: str) -> str | None:
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXT, name)
    if i < 0:
        return None
    adr, size = int(m.text_adr[i]), int(m.text_size[i])
    return bytes(m.text_data[adr : adr + size]).rstrip(b"\x00").decode()


def _custom_numeric(m: mujoco.MjModel, name: str) -> np.ndarray | None:
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, name)
    if i < 0:
        return None
    adr, size = int(m.numeric_adr[i]), int(m.numeric_size[i])
    return np.array(m.numeric_data[adr : adr + size])


def body_is_moving(m: mujoco.MjModel, body: int) -> bool:
    """True when some joint moves ``body`` (the body or one of its ancestors has a joint)."""
    while body != 0:
        if m.body_jntnum[body] > 0:
            return True
        body = int(m.body_parentid[body])
    return False


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
        out = np.broadcast_to(self.qpos0, q.shape[:-1] + self.qpos0.shape).copy()
        out[..., self.qpos_index] = self.offset + self.scale * q
        return out

    def to_q(self, qpos: np.ndarray) -> np.ndarray:
        """Configurations for qpos rows of shape (nq,) or (N, nq)."""
        qpos = np.asarray(qpos, dtype=float)
        return (qpos[..., self.qpos_index] - self.offset) / self.scale


@dataclass
class RobotModel:
    """A compiled MJCF scene with its configuration map and its robot/obstacle geom pairs."""

    path: Path
    model: mujoco.MjModel
    config: ConfigurationMap
    robot_geoms: np.ndarray  # geom ids
    obstacle_geoms: np.ndarray  # geom ids
    pairs: np.ndarray  # (P, 2) geom ids (robot, obstacle)
    _data: mujoco.MjData = field(repr=False, default=None)  # type: ignore[assignment]
    spec: mujoco.MjSpec | None = field(repr=False, default=None)  # what ``model`` was compiled from
    xml: str | None = field(repr=False, default=None)  # the edited scene's MJCF when it differs from ``path``

    def __post_init__(self) -> None:
        # Per-geom masks for in_collision, computed once rather than on every call.
        ids = np.arange(self.model.ngeom)
        self._is_robot = np.isin(ids, self.robot_geoms)
        self._is_obstacle = np.isin(ids, self.obstacle_geoms)

    @classmethod
    def from_xml(
        cls,
        path: str | Path,
        joints: Sequence[str] | None = None,
        normalize: Mapping[str, Sequence[float]] | None = None,
    ) -> "RobotModel":
        """Load an MJCF scene and read its configuration (see the module docstring).

        ``joints`` and ``normalize`` (joint name -> [span] or [qpos_lo, qpos_hi, span]) override the MJCF's
        declaration, as a scenario's ``joints = [...]`` and ``[normalize]`` do.
        """
        p = Path(path).resolve()
        return cls.from_spec(load_spec(p), p, joints, normalize)

    @classmethod
    def from_spec(
        cls,
        spec: mujoco.MjSpec,
        path: str | Path,
        joints: Sequence[str] | None = None,
        normalize: Mapping[str, Sequence[float]] | None = None,
    ) -> "RobotModel":
        """Build from a (possibly edited) :class:`mujoco.MjSpec`; ``path`` names the source in messages.

        Unnamed geoms are named in ``spec`` (module docstring); the spec is kept (:meth:`spec_copy`).
        """
        p = Path(path)
        compile_spec(spec, p)
        name_unnamed_geoms(spec)
        m = compile_spec(spec, p)
        config = _configuration_map(m, p, joints, normalize)
        robot, obstacles = [], []
        for g in range(m.ngeom):
            if not (m.geom_contype[g] or m.geom_conaffinity[g]):
                continue
            (robot if body_is_moving(m, int(m.geom_bodyid[g])) else obstacles).append(g)
        if not robot:
            raise ModelError(f"{p}: no collision geom is attached to a moving body (the robot)")
        if not obstacles:
            raise ModelError(f"{p}: no collision geom is attached to a static body (the obstacles)")
        pairs = [
            (g, o)
            for g in robot
            for o in obstacles
            if (m.geom_contype[g] & m.geom_conaffinity[o]) or (m.geom_contype[o] & m.geom_conaffinity[g])
        ]
        if not pairs:
            raise ModelError(f"{p}: contype/conaffinity let no robot geom collide with any obstacle geom")
        nonzero = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or str(g) for g in robot + obstacles if m.geom_margin[g] != 0]
        if nonzero:
            raise ModelError(
                f"{p}: collision geoms {nonzero} have a non-zero margin; mj_geomDistance subtracts margins, "
                "so clearances would be wrong. Set margin=\"0\" on collision geoms."
            )
        out = cls(p, m, config, np.array(robot), np.array(obstacles), np.array(pairs, dtype=int), mujoco.MjData(m))
        out.spec = spec
        return out

    def spec_copy(self) -> mujoco.MjSpec:
        """A fresh, editable copy of the spec this model was compiled from (e.g. to add sensors)."""
        if self.spec is None:
            spec = load_spec(self.path)
            name_unnamed_geoms(spec)
            return spec
        return self.spec.copy()

    # -- configuration helpers -------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return self.config.dim

    @property
    def lower(self) -> np.ndarray:
        return self.config.lower

    @property
    def upper(self) -> np.ndarray:
        return self.config.upper

    def geom_name(self, g: int) -> str:
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"geom{g}"

    def validate(self, q, name: str = "q", *, check_bounds: bool = True) -> np.ndarray:
        """Return q as a float array of shape (n,), or raise ConfigurationError saying what is wrong."""
        try:
            arr = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise ConfigurationError(f"{name} must be a sequence of {self.dim} numbers, got {q!r}") from None
        if arr.shape != (self.dim,):
            raise ConfigurationError(
                f"{name} must have shape ({self.dim},) ({', '.join(self.config.joint_names)}), got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"{name} must be finite, got {arr.tolist()}")
        if check_bounds:
            bad = np.flatnonzero((arr < self.lower) | (arr > self.upper))
            if bad.size:
                i = int(bad[0])
                raise ConfigurationError(
                    f"{name}[{i}] ({self.config.joint_names[i]}) = {arr[i]:.6g} is outside its bounds "
                    f"[{self.lower[i]:.6g}, {self.upper[i]:.6g}]"
                )
        return arr

    def validate_batch(self, Q, name: str = "Q") -> np.ndarray:
        """Return Q as a float array of shape (N, n), or raise ConfigurationError."""
        arr = np.asarray(Q, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != self.dim:
            raise ConfigurationError(f"{name} must have shape (N, {self.dim}), got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"{name} must be finite")
        return arr

    def set_configuration(self, q: np.ndarray, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """Set qpos from q and run forward kinematics (``mj_kinematics``); returns the MjData used."""
        d = self._data if data is None else data
        d.qpos[:] = self.config.to_qpos(q)
        mujoco.mj_kinematics(self.model, d)
        return d

    def in_collision(self, q: np.ndarray, data: mujoco.MjData | None = None) -> bool:
        """MuJoCo's own contact detection (``mj_collision``): True when any robot geom touches an obstacle.

        This is independent of the clearance code and is what tests use to check bubbles.
        """
        d = self.set_configuration(q, data)
        mujoco.mj_collision(self.model, d)
        g = d.contact.geom[: d.ncon]
        if len(g) == 0:
            return False
        hit = np.asarray(d.contact.dist[: d.ncon]) <= 0
        leg, obs = self._is_robot, self._is_obstacle
        return bool(np.any(hit & ((leg[g[:, 0]] & obs[g[:, 1]]) | (leg[g[:, 1]] & obs[g[:, 0]]))))



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
        raise ModelError(f"{path}: configuration joint '{name}' is not in the model (joints: {known})")
    kind = int(m.jnt_type[j])
    if kind not in _SUPPORTED_JOINTS:
        raise ModelError(
            f"{path}: configuration joint '{name}' is {_JOINT_TYPE_NAMES.get(kind, 'not a hinge or slide')}; "
            "foam-mj plans over hinge and slide joints only (leave it out of the configuration)"
        )
    if not m.jnt_limited[j]:
        raise ModelError(
            f"{path}: configuration joint '{name}' has no range; the bounds of q come from it "
            "(add range=\"lo hi\" to the joint, or leave it out of the configuration)"
        )
    return j


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
    unknown = set(normalize) - set(names)
    if unknown:
        raise ModelError(f"{path}: normalization given for {sorted(unknown)}, which are not configuration joints {names}")
    ids, adr, scale, offset, lo, hi = [], [], [], [], [], []
    for name in names:
        j = check_configuration_joint(m, path, name)
        jlo, jhi = (float(v) for v in m.jnt_range[j])
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
            if not (span > 0 and b > a):
                raise ModelError(f"{path}: {where} needs span > 0 and qpos_hi > qpos_lo")
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
