"""What ``plan`` and ``replay`` print: the per-path summary table, the joint loads, the servo and timestep notes,
the Pareto fronts and the optimal smoother's certificates. Heavy modules are imported inside each function."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def fmt_q(q: ArrayLike) -> str:
    import numpy as np

    return "[" + ", ".join(f"{v:g}" for v in np.asarray(q)) + "]"


def fmt_mm(metres: float) -> str:
    """A clearance in millimetres: one decimal from 1 mm up, three significant digits below (a 50 um clearance of a
    millimetre-sized robot, margin 5 um, read "0.0 mm", as if it touched)."""
    mm = metres * 1000
    return f"{mm:.1f} mm" if abs(mm) >= 1 else f"{mm:.3g} mm"


def summary_table(outcome) -> str:
    """The per-path summary printed by ``plan`` and ``replay``."""
    import numpy as np

    head = f"{'path':<27}{'length':>8}{'f':>8}{'TC':>8}{'SV':>8}{'min clear':>11}{'duration':>10}{'track err':>10}{'contacts':>9}{'time':>9}"
    lines = [head, "-" * len(head)]
    for po in outcome.paths.values():
        m = po.metrics
        clear = fmt_mm(po.kinematic.min_clearance) if po.kinematic is not None else "-"
        dur = f"{po.trajectory.duration:.2f} s" if po.trajectory is not None else "no timing" if po.timing_error is not None else "-"
        err = "-" if po.dynamic is None else "unstable" if po.dynamic.diverged else f"{np.max(po.dynamic.max_error) * 1000:.2f}"
        con = str(len(po.dynamic.contacts)) if po.dynamic is not None else "-"
        lines.append(
            f"{po.label:<27}{m.length:>8.4f}{m.f:>8.4f}{m.tc:>8.4f}{m.sv:>8.4f}{clear:>11}{dur:>10}{err:>10}{con:>9}"
            f"{po.result.wall_time * 1000:>7.0f} ms"
        )
    lines.append(_legend(outcome.paths.values()))
    return "\n".join(lines)


def _legend(paths) -> str:
    """The summary's last line: what its replay columns mean, for those that have values. With ``--no-replay`` it
    explained a servo replay that never ran, under columns of dashes; those now read as not computed."""
    paths = list(paths)
    kinematic = any(po.kinematic is not None for po in paths)
    dynamic = any(po.dynamic is not None for po in paths)
    notes = []
    if kinematic:
        notes.append("min clear: smallest MuJoCo clearance along the planned trajectory")
    if dynamic:
        notes.append("track err: largest servo tracking error under gravity (mrad for hinges, mm for slides); "
                     "contacts: robot/obstacle contacts in that servo replay")
    missing = [name for name, has in (("min clear", kinematic), ("duration", any(po.trajectory is not None for po in paths)),
                                      ("track err", dynamic), ("contacts", dynamic)) if not has]
    if missing:
        notes.append(f"{', '.join(missing)}: not computed (no replay)")
    return "; ".join(notes) + "."


def print_servo_note(outcome) -> None:
    """One line when the dynamic replay had to add servos to the model (foam_mj.servos.servo_model), with each
    joint's kp (its range over the paths: they are sized per path), and one per path whose servos ran into their
    ctrl or force range (DynamicReplay.limit_note)."""
    import numpy as np

    added = [po.dynamic for po in outcome.paths.values() if po.dynamic is not None and po.dynamic.servo_note]
    for note in sorted({dyn.servo_note for dyn in added}):
        kp = np.array([dyn.servo_kp for dyn in added if dyn.servo_note == note])
        lo, hi = kp.min(axis=0), kp.max(axis=0)
        gains = ", ".join(f"{name} {a:.4g}" if f"{a:.4g}" == f"{b:.4g}" else f"{name} {a:.4g}-{b:.4g}"
                          for name, a, b in zip(added[0].joint_names, lo, hi))
        print(f"note: {note}: kp {gains} (N m/rad or N/m)")
    delta = getattr(getattr(getattr(outcome, "scenario", None), "params", None), "delta", None)
    for po in outcome.paths.values():
        if po.dynamic is not None and po.dynamic.limit_note:
            print(f"note: {po.label}: dynamic replay: {po.dynamic.limit_note}")
        if delta is not None and po.dynamic is not None and not po.dynamic.diverged:
            note = closer_than_margin(po, delta)
            if note:
                print(f"note: {po.label}: dynamic replay: {note}")
        if po.dynamic is not None and po.dynamic.diverged:
            print(f"note: {po.label}: dynamic replay: MuJoCo's simulation diverged ({', '.join(po.dynamic.diverged)}) and "
                  f"restarted from the model's initial state, so its tracking error and contacts mean nothing (likely cause: "
                  f"{po.dynamic.divergence_cause}); the planned path and its clearance do not depend on this replay")


def closer_than_margin(po, delta: float) -> str:
    """The simulated robot's approach under the margin ``delta`` in the servo replay of path ``po`` ("" when it kept
    it): how close, in how many frames and from when, and the contacts; the table's ``min clear`` is the planned
    trajectory's, so a servo that lags (force range, model) could take the robot under the margin unseen."""
    import numpy as np

    dyn = po.dynamic
    clear = np.asarray(dyn.clearance, dtype=float)
    below = clear < delta
    if not below.any():
        return ""
    planned = fmt_mm(po.kinematic.min_clearance) if po.kinematic is not None else "-"
    return (f"the simulated robot came within {fmt_mm(clear.min())} of contact (margin {fmt_mm(delta)}; {int(below.sum())} "
            f"of {len(clear)} frames, from t = {dyn.times[np.argmax(below)]:.3f} s; {len(dyn.contacts)} contacts) where the "
            f"planned trajectory keeps {planned}: the servos' tracking (track err), not the path")


def print_row_cap_note(outcome) -> None:
    """One line when the model's timestep, not the joint limits, held some joint's acceleration (so that
    consecutive trajectory rows stay close to the certified curve: foam_mj.trajectory.row_acceleration_cap)."""
    from foam_mj.dynamics import joint_units
    from foam_mj.trajectory import ROW_TOL, row_acceleration_cap

    timed = [po.trajectory for po in outcome.paths.values() if po.trajectory is not None]
    if not timed:
        return
    robot = outcome.scenario.robot
    dt = timed[0].dt
    _, acc, _ = outcome.limits.resolve(robot)
    cap = row_acceleration_cap(robot, dt)
    held = [f"{name} {c:.3g} {unit[2]} (limit {a:g})" for name, c, a, unit in
            zip(robot.config.joint_names, cap, acc, joint_units(robot)) if c < a]
    if held:
        print(f"note: at the model's timestep of {dt:g} s, accelerations are held to {', '.join(held)}, so that the "
              f"straight line between consecutive trajectory rows stays within {ROW_TOL:g} of the certified curve")


def print_limits_note(outcome) -> None:
    """One line when an MJCF written in degrees declares a hinge's time-law limits in ``foam_mj:limits:<joint>``: MuJoCo
    converts the model's angles, never a custom field's numbers, so "180 720" is 180 rad/s (10,313 deg/s), not 180 deg/s."""
    import numpy as np

    from foam_mj.configuration import HINGE
    from foam_mj.mjcf import _custom_numeric
    from foam_mj.trajectory import LIMITS_PREFIX

    robot = outcome.scenario.robot
    if robot.spec is None or not robot.spec.compiler.degree:
        return
    limits = outcome.limits
    vel, acc, _ = limits.resolve(robot)
    read = [
        f"{name} {v:g} rad/s ({np.degrees(v):,.0f} deg/s), {a:g} rad/s^2"
        for name, j, v, a in zip(robot.config.joint_names, robot.config.joint_ids, vel, acc)
        if int(robot.model.jnt_type[j]) == HINGE and name not in limits.joint.per_joint
        and limits.velocity is None and limits.acceleration is None and _custom_numeric(robot.model, LIMITS_PREFIX + name) is not None
    ]
    if read:
        print(f"note: {LIMITS_PREFIX}<joint> limits are in radians, whatever the MJCF's <compiler angle=\"degree\"> "
              f"(MuJoCo converts no custom field): {'; '.join(read)}")


def print_replay_notes(outcome) -> None:
    """What ``plan`` and ``replay`` print after the summary table: the servo, limits and timestep notes, then the joint loads."""
    print_servo_note(outcome)
    print_limits_note(outcome)
    print_row_cap_note(outcome)
    loads = loads_table(outcome)
    if loads:
        print(loads)


def loads_table(outcome) -> str:
    """Per path and joint: peak and RMS torque (mj_inverse), per kilogram, the actuator limit and its use,
    positive and negative work; then the human reference (foam_mj.dynamics.HUMAN_SWING)."""
    import numpy as np

    from foam_mj.dynamics import HUMAN_SWING

    rows = [(po.label, po.loads) for po in outcome.paths.values() if getattr(po, "loads", None) is not None]
    if not rows:
        return ""
    law = getattr(outcome, "time_law", "")
    head = f"{'path':<27}{'joint':<18}{'peak':>11}{'RMS':>11}{'per kg':>8}{'limit':>11}{'use':>6}{'work +':>9}{'work -':>9}"
    lines = [f"joint loads (mj_inverse along each trajectory, timed by {law}):", head, "-" * len(head)]
    any_kg = False
    for label, L in rows:
        per_kg = L.per_kg
        for j, joint in enumerate(L.joint_names):
            unit = L.torque_units[j]
            kg = "-"
            if per_kg is not None and unit == "N m":
                kg, any_kg = f"{per_kg[j]:.2f}", True
            lim = "none" if not np.isfinite(L.limit[j]) else f"{L.limit[j]:.0f} {unit}" if L.limit[j] < 1e6 else f"{L.limit[j]:.2g} {unit}"
            use = f"{100 * L.use[j]:.0f}%" if np.isfinite(L.limit[j]) else "-"
            lines.append(
                f"{label if j == 0 else '':<27}{joint:<18}{L.peak[j]:>7.1f} {unit:<3}{L.rms[j]:>7.1f} {unit:<3}{kg:>8}{lim:>11}{use:>6}"
                f"{L.positive_work[j]:>7.1f} J{L.negative_work[j]:>7.1f} J"
            )
    lines.append("peak/RMS: joint torque (N m) or force (N); per kg: peak per kilogram of body mass (N m/kg); use: peak / the "
                 "torque limit (the actuator's force range, a motor's control range times its gain, unless [limits] sets one); work +/-: energy the joint supplies / absorbs.")
    if any_kg:
        h = HUMAN_SWING
        lines.append(f"human reference, swing of normal walking ({h.source.split(',')[0]}): peak hip {h.hip:.2f} N m/kg, knee {h.knee:.2f} N m/kg")
    return "\n".join(lines)


def print_fronts(outcome) -> None:
    """For multi-objective smoothers: the front's extremes and knee, and the gap to the convex length."""
    import numpy as np

    convex = outcome.paths.get("convex")
    for name, po in outcome.paths.items():
        front = po.result.info.get("front") if po.result.info else None
        if front is None:
            continue
        F = np.asarray(front["objectives"], dtype=float)
        knee = front.get("knee")
        print(f"{po.label}: Pareto front of {len(F)} paths (length, angle term)")
        rows = [("shortest", int(np.argmin(F[:, 0]))), ("smoothest", int(np.argmin(F[:, 1])))]
        if knee is not None:
            rows.append(("knee", int(knee)))
        for label, i in rows:
            gap = f", {100 * (F[i, 0] / convex.metrics.length - 1):+.2f}% vs convex length" if convex is not None else ""
            print(f"  {label:<9} length {F[i, 0]:.4f}  angle term {F[i, 1]:.4f}{gap}")


def print_certificates(outcome) -> None:
    """For the optimal smoother: whether its path is a certified local optimum, and its gain on the convex path."""
    convex = outcome.paths.get("convex")
    for po in outcome.paths.values():
        info = po.result.info or {}
        if "kkt_stationarity" not in info:
            continue
        gain = f"; f {100 * (po.metrics.f / convex.metrics.f - 1):+.2f}% vs convex" if convex is not None else ""
        if info.get("certified"):
            verdict, residual = "certified local optimum", f"KKT residual {info['kkt_stationarity']:.1e}"
        else:
            verdict = "NOT certified as a local optimum"
            residual = f"KKT residual {info['kkt_stationarity']:.1e}, complementarity {info.get('kkt_complementarity', float('nan')):.1e}"
        print(
            f"{po.label}: {verdict} of {po.result.objective} ({residual}, tolerance "
            f"{info['kkt_tol']:.0e}; {info['straight_vertices']} straight vertices, {info['active_constraints']} active "
            f"hatch constraints) in {1e3 * po.result.wall_time:.0f} ms{gain}"
        )
