"""Random serial chains for property tests: hinges and slides in random order on random axes, random
``ref`` offsets, random primitive geoms, random static obstacles, written as MJCF text."""

from __future__ import annotations

import numpy as np

_TYPES = ("sphere", "capsule", "box", "cylinder", "ellipsoid")


def _vec(v) -> str:
    return " ".join(f"{x:.6g}" for x in v)


def _axis(rng: np.random.Generator) -> np.ndarray:
    """Half the time a coordinate axis (planar chains are a special case of the bound), else random."""
    if rng.random() < 0.5:
        a = np.zeros(3)
        a[rng.integers(3)] = rng.choice([-1.0, 1.0])
        return a
    a = rng.standard_normal(3)
    return a / np.linalg.norm(a)


def _geom(rng: np.random.Generator, name: str, attrs: str = "") -> str:
    kind = _TYPES[rng.integers(len(_TYPES))]
    size = {
        "sphere": [rng.uniform(0.02, 0.08)],
        "capsule": [rng.uniform(0.02, 0.06), rng.uniform(0.03, 0.15)],
        "box": rng.uniform(0.02, 0.1, 3),
        "cylinder": [rng.uniform(0.02, 0.06), rng.uniform(0.03, 0.12)],
        "ellipsoid": rng.uniform(0.02, 0.08, 3),
    }[kind]
    pos = rng.uniform(-0.15, 0.15, 3)
    euler = rng.uniform(-np.pi, np.pi, 3)
    return f'<geom name="{name}" type="{kind}" size="{_vec(size)}" pos="{_vec(pos)}" euler="{_vec(euler)}" {attrs}/>'


def random_chain_xml(
    rng: np.random.Generator,
    *,
    joints: tuple[int, int] = (2, 4),
    obstacles: tuple[int, int] = (2, 4),
    self_collision: bool = False,
) -> str:
    """An MJCF scene: a chain of bodies from the world, each with one or two hinge/slide joints (random
    axes, anchors, ``ref`` and ranges) and zero to two geoms, plus static obstacles around it.

    Robot geoms collide with obstacles; with ``self_collision`` they also collide with each other
    (otherwise contype/conaffinity keep them apart)."""
    n = int(rng.integers(joints[0], joints[1] + 1))
    robot_attr = 'contype="1" conaffinity="1"' if self_collision else 'contype="1" conaffinity="2"'
    lines = ['<mujoco><compiler angle="radian"/><worldbody>']
    close = []
    made, body = 0, 0
    geom_id = 0
    while made < n:
        pos = rng.uniform(-0.35, 0.35, 3) if body else np.zeros(3)
        euler = rng.uniform(-np.pi, np.pi, 3) if rng.random() < 0.5 else np.zeros(3)
        lines.append(f'<body name="b{body}" pos="{_vec(pos)}" euler="{_vec(euler)}">')
        lines.append('<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>')
        for _ in range(min(int(rng.integers(1, 3)), n - made)):
            if rng.random() < 0.5:
                lo, hi = -rng.uniform(0.2, 2.0), rng.uniform(0.2, 2.0)
                ref = rng.uniform(-1.0, 1.0)
                kind = "hinge"
            else:
                lo, hi = -rng.uniform(0.0, 0.4), rng.uniform(0.1, 0.4)
                ref = rng.uniform(-0.4, 0.4)
                kind = "slide"
            jpos = rng.uniform(-0.2, 0.2, 3)
            lines.append(
                f'<joint name="j{made}" type="{kind}" axis="{_vec(_axis(rng))}" pos="{_vec(jpos)}" '
                f'ref="{ref:.6g}" range="{lo:.6g} {hi:.6g}"/>'
            )
            made += 1
        k = int(rng.integers(0, 3)) if made < n else int(rng.integers(1, 3))
        for _ in range(k):
            lines.append(_geom(rng, f"g{geom_id}", robot_attr))
            geom_id += 1
        close.append("</body>")
        body += 1
    lines.extend(reversed(close))
    for i in range(int(rng.integers(obstacles[0], obstacles[1] + 1))):
        centre = rng.uniform(-0.9, 0.9, 3)
        lines.append(
            f'<geom name="obstacle{i}" type="box" size="{_vec(rng.uniform(0.05, 0.3, 3))}" pos="{_vec(centre)}" '
            f'euler="{_vec(rng.uniform(-np.pi, np.pi, 3))}" contype="2" conaffinity="1"/>'
        )
    if rng.random() < 0.5:  # a floor below the chain (planes get their own rule for joints that cannot change d)
        lines.append(f'<geom name="floor" type="plane" size="3 3 0.1" pos="0 0 {-rng.uniform(0.8, 1.2):.6g}" contype="2" conaffinity="1"/>')
    lines.append("</worldbody></mujoco>")
    return "\n".join(lines)
