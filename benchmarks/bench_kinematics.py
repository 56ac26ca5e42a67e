"""Speed of denavit's kinematics and IK, side by side with roboticstoolbox-python and pinocchio when installed
(`pip install -e ".[bench]"`). A script that prints a table, not a timed test.

    python benchmarks/bench_kinematics.py [--quick] [--json out.json]

Every case uses the TianSui-One arm of Guo et al. (MDH Table I; the Guo trajectory also ED-H Table II). The
other libraries get the same chain, built from denavit's joint placements (rtb: an ETS of constant SE3 and
Rz factors, whose ik_LM / fkine / jacob0 run in rtb's C++; pinocchio: revolute-z joints at those placements),
and every IK answer, ours included, is judged here from its measured pose error, never from the library's flag.
Reported figures are medians over repeats. BLAS threads are pinned to 1 (they only spin on this workload).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import denavit as dv  # noqa: E402

try:
    import roboticstoolbox as rtb
    from roboticstoolbox import ET, ETS
except ImportError:  # optional
    rtb = None
try:
    import pinocchio as pin
except ImportError:  # optional
    pin = None


# --- helpers ----------------------------------------------------------------------------------------------


def pose_error(A, B):
    """Position (m) and rotation angle (rad) between two poses."""
    dp = np.linalg.norm(A[:3, 3] - B[:3, 3])
    R = A[:3, :3].T @ B[:3, :3]
    s = np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2
    return dp, float(np.arctan2(s, (np.trace(R) - 1) / 2))


def per_call(fn, number, repeat, clock=time.perf_counter):
    """Median over `repeat` runs of the mean time of one call (s), by `clock` (as in `once`)."""
    fn()
    runs = []
    for _ in range(repeat):
        t = clock()
        for _ in range(number):
            fn()
        runs.append((clock() - t) / number)
    return float(np.median(runs))


def once(fn, repeat, clock=time.perf_counter):
    """Median over `repeat` runs of one call (s), by `clock` (wall time; `time.thread_time` for the CPU time of
    the calling thread, which on a loaded machine leaves out the time the thread waited for a core)."""
    fn()
    runs = []
    for _ in range(repeat):
        t = clock()
        fn()
        runs.append(clock() - t)
    return float(np.median(runs))


def rz(t):
    c, s = np.cos(t), np.sin(t)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def guo_targets():
    """Guo et al. sec. V: 0T (4 decimals, re-orthonormalised), then 100 targets along base +Z in 1 mm steps."""
    T0 = np.array(
        [
            [-0.7598, 0.4151, 0.5004, -0.3655],
            [-0.4391, 0.2399, -0.8658, -0.3712],
            [-0.4794, -0.8776, 0.0000, -0.0245],
            [0, 0, 0, 1.0],
        ]
    )
    U, _, Vt = np.linalg.svd(T0[:3, :3])
    T0[:3, :3] = U @ Vt
    targets = np.repeat(T0[None], 100, axis=0)
    targets[:, 2, 3] += 0.001 * np.arange(1, 101)
    return T0, targets


# --- the same chain in the other libraries ------------------------------------------------------------------


def rtb_robot(model):
    assert np.allclose(model.T_world_base, np.eye(4)) and np.allclose(model.T_flange_tool, np.eye(4))
    ets = ETS()
    for P, off in zip(model.placements, model.offsets):
        ets = ets * ET.SE3(P) * ET.Rz(off) * ET.Rz()
    return rtb.Robot(ets)


def pin_model(model):
    assert np.allclose(model.T_world_base, np.eye(4)) and np.allclose(model.T_flange_tool, np.eye(4))
    pm = pin.Model()
    parent = 0
    for i, (P, off) in enumerate(zip(model.placements, model.offsets)):
        M = P @ rz(off)
        parent = pm.addJoint(parent, pin.JointModelRZ(), pin.SE3(M[:3, :3], M[:3, 3]), f"j{i + 1}")
    return pm, pm.createData(), parent


def pin_ik(pm, pd, jid, T, q0, tol=1e-9, it_max=100, damp=1e-12):
    """pinocchio's inverse-kinematics example (CLIK: log6 error, Jlog6, damped least squares), full steps."""
    oMdes = pin.SE3(T[:3, :3], T[:3, 3])
    q = np.array(q0, float)
    for _ in range(it_max):
        pin.forwardKinematics(pm, pd, q)
        iMd = pd.oMi[jid].actInv(oMdes)
        err = pin.log(iMd).vector
        if np.linalg.norm(err[:3]) < tol and np.linalg.norm(err[3:]) < tol:
            break
        J = pin.computeJointJacobian(pm, pd, q, jid)
        J = -pin.Jlog6(iMd.inverse()) @ J
        v = -J.T @ np.linalg.solve(J @ J.T + damp * np.eye(6), err)
        q = pin.integrate(pm, q, v)
    return q


def rtb_robot_with_limits(model):
    """rtb's Robot of any chain of revolute joints (base, placements, offsets, tool) with the model's limits."""
    ets = ETS()
    if not np.allclose(model.T_world_base, np.eye(4)):
        ets = ets * ET.SE3(model.T_world_base)
    for P, off in zip(model.placements, model.offsets):
        ets = ets * ET.SE3(P) * ET.Rz(off) * ET.Rz()
    ets = ets * ET.SE3(model.T_last_tool)
    robot = rtb.Robot(ets)
    robot.qlim = np.array([model.lower, model.upper])
    return robot


def pin_model_with_tool(model):
    """pinocchio's model of any chain of revolute joints, with the tool as an operational frame."""
    pm = pin.Model()
    parent = 0
    for i, (P, off) in enumerate(zip(model.placements, model.offsets)):
        M = (model.T_world_base @ P if i == 0 else P) @ rz(off)
        parent = pm.addJoint(parent, pin.JointModelRZ(), pin.SE3(M[:3, :3], M[:3, 3]), f"j{i + 1}")
    T = model.T_last_tool
    fid = pm.addFrame(pin.Frame("tool", parent, 0, pin.SE3(T[:3, :3], T[:3, 3]), pin.FrameType.OP_FRAME))
    return pm, pm.createData(), fid


def pin_ik_frame(pm, pd, fid, T, q0, tol=1e-9, it_max=100, damp=1e-12):
    """pinocchio's CLIK example on an operational frame: log6 error in the frame, Jlog6, damped least squares."""
    oMdes = pin.SE3(T[:3, :3], T[:3, 3])
    q = np.array(q0, float)
    for _ in range(it_max):
        pin.framesForwardKinematics(pm, pd, q)
        iMd = pd.oMf[fid].actInv(oMdes)
        err = pin.log(iMd).vector
        if np.linalg.norm(err[:3]) < tol and np.linalg.norm(err[3:]) < tol:
            break
        J = pin.computeFrameJacobian(pm, pd, q, fid, pin.LOCAL)
        J = -pin.Jlog6(iMd.inverse()) @ J
        v = -J.T @ np.linalg.solve(J @ J.T + damp * np.eye(6), err)
        q = pin.integrate(pm, q, v)
    return q


def iiwa14():
    """The KUKA LBR iiwa 14 R820, a second 7R arm (standard DH: d = 0.36, 0, 0.42, 0, 0.4, 0, 0.126 m, a = 0,
    alpha = -90, 90, 90, -90, -90, 90, 0 deg; limits +-170, 120, 170, 120, 170, 120, 175 deg): joint i's placement
    is link i-1's DH transform Tz(d) Rx(alpha), the last one's the flange."""

    def dh(d, alpha):
        c, s = np.cos(alpha), np.sin(alpha)
        T = np.eye(4)
        T[1:3, 1:3] = [[c, -s], [s, c]]
        T[2, 3] = d
        return T

    d = (0.36, 0.0, 0.42, 0.0, 0.4, 0.0, 0.126)
    alpha = np.radians([-90, 90, 90, -90, -90, 90, 0])
    placements = np.array([np.eye(4)] + [dh(d[i], alpha[i]) for i in range(6)])
    lim = np.radians([170, 120, 170, 120, 170, 120, 175])
    return dv.Model.from_placements(
        placements, ["revolute"] * 7, lower=-lim, upper=lim, T_last_flange=dh(d[6], alpha[6]), name="iiwa14"
    )


def ik_one_attempt(models, n, have_rtb, have_pin, tol=1e-9, respect_limits=True):
    """One attempt (no restarts, 100 iterations) from q0 = 0.3 rad on random reachable targets (q uniform within
    the limits, clipped to +-pi; generator seed 7 per robot): the success rate judged here from the measured pose
    error (and the limits) and the median time per solve, for denavit's Newton and LM, rtb's ik_NR / ik_LM
    (slimit=1: one search from the same q0, ilimit=100, joint_limits=True) and pinocchio's CLIK (a Python loop
    over its C++ calls). With `respect_limits=False` no solver is held to the limits nor judged on them, and q0 is
    0.3 rad at every joint (with the limits, q0 is clipped into them: the Panda's q4 <= -0.07 rad). rtb gets the
    same targets and start on the same chain, built from denavit's table (its own models.DH.Puma560 / UR5 / KR5 are
    other robots: a 0.672 m base height, d1 = 89.459 mm and +-180 deg
    limits, other axis senses; checked here by FK at 5 configurations). denavit's first attempt starts from the
    closed-form branches of the 6R built-ins (within the limits, nearest q0 first, polished by Newton) whatever
    the method; the 7-joint arms (Panda, iiwa) start from the semi-analytic seeds (q7 sampled from q0's outwards,
    each sample's 6R in closed form, nearest q0 first). Every solver's solves are timed back to back and judged
    afterwards (:func:`timed`); denavit's are timed a second time with each judged before the next, whose numpy
    work between the calls leaves the solver's code and data out of the caches (about 2-3 us more per solve on
    a 2 GHz server core)."""
    rows = []
    for name, m in models:
        rng = np.random.default_rng(7)
        lo, hi = np.maximum(m.lower, -np.pi), np.minimum(m.upper, np.pi)
        qs = rng.uniform(lo, hi, (n, m.nq))
        Ts = dv.fk_batch(m, qs)
        q0 = np.clip(np.full(m.nq, 0.3), m.lower, m.upper) if respect_limits else np.full(m.nq, 0.3)

        def judge(q, T, m=m):
            within = not respect_limits or bool(np.all((q >= m.lower) & (q <= m.upper)))
            return max(pose_error(dv.fk(m, q), T)) <= tol + 1e-15 and within

        cells = []
        for method in ("newton", "lm"):
            # timed as :func:`timed` does, without a wrapper function around the call
            times, results = [], []
            for T in Ts:
                t = time.perf_counter()
                r = dv.ik(
                    m,
                    T,
                    q0,
                    method=method,
                    restarts=0,
                    tol_position=tol,
                    tol_rotation=tol,
                    respect_limits=respect_limits,
                )
                times.append(time.perf_counter() - t)
                results.append(r)
            ok = sum(judge(r.q, T) and r.success for r, T in zip(results, Ts))
            # the same solves, each judged before the next (numpy work between solves: colder caches)
            between = []
            for T in Ts:
                t = time.perf_counter()
                r = dv.ik(
                    m,
                    T,
                    q0,
                    method=method,
                    restarts=0,
                    tol_position=tol,
                    tol_rotation=tol,
                    respect_limits=respect_limits,
                )
                between.append(time.perf_counter() - t)
                judge(r.q, T)
            cells.append(
                f"{100 * ok / n:.1f} %, {np.median(times) * 1e6:.2f} us ({np.median(between) * 1e6:.2f} us between"
                " other work)"
            )
        for solver in ("ik_NR", "ik_LM") if have_rtb else ():
            robot = rtb_robot_with_limits(m)
            assert all(np.allclose(robot.fkine(q).A, dv.fk(m, q), atol=1e-12) for q in qs[:5]), (
                f"rtb's {name} is not ours"
            )
            times, results = timed(
                Ts,
                lambda T, robot=robot, solver=solver, q0=q0: getattr(robot, solver)(
                    T, q0=q0, ilimit=100, slimit=1, tol=1e-20, joint_limits=respect_limits
                ),
            )
            ok = sum(judge(np.asarray(s[0] if isinstance(s, tuple) else s.q), T) for s, T in zip(results, Ts))
            cells.append(f"{100 * ok / n:.1f} %, {np.median(times) * 1e6:.2f} us")
        if have_pin:
            pm, pd, fid = pin_model_with_tool(m)
            k = max(20, n // 5)
            times, results = timed(
                Ts[:k], lambda T, pm=pm, pd=pd, fid=fid, q0=q0: pin_ik_frame(pm, pd, fid, T, q0, tol=tol)
            )
            ok = sum(max(pose_error(dv.fk(m, q), T)) <= tol + 1e-15 for q, T in zip(results, Ts[:k]))
            cells.append(
                f"{100 * ok / k:.1f} %, {np.median(times) * 1e6:.2f} us ({k} targets, limits not enforced nor judged)"
            )
        else:
            cells.append("-")
        rows.append((name + ("" if respect_limits else ", no limits"), *cells))
    return rows


def timed(targets, solve):
    """(time of each solve (s), the results): the solves back to back, as a path or a batch runs them; the
    results are judged afterwards, so the judging's numpy work does not run between the timed calls."""
    times, results = [], []
    for T in targets:
        t = time.perf_counter()
        r = solve(T)
        times.append(time.perf_counter() - t)
        results.append(r)
    return times, results


def print_one_attempt(rows, have_rtb):
    print(
        "IK, one attempt (restarts=0, 100 iterations) from q0 = 0.3 rad, random reachable targets, pose error <= 1e-9"
        " and within limits (rows 'no limits': limits neither enforced nor judged): success rate, median time per"
        " solve, solves back to back, judged afterwards (denavit's: in brackets, each solve judged before the next)"
        " (target: >= 97 %, <= 5 us, never below rtb)"
    )
    head = (
        "robot",
        "denavit newton",
        "denavit lm",
        *(("rtb ik_NR", "rtb ik_LM") if have_rtb else ()),
        "pinocchio CLIK (Python loop)",
    )
    if not have_rtb:
        print("(roboticstoolbox not installed or --no-compare: no rtb columns)")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print("| " + " | ".join(r) + " |")


# --- the cases ----------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats (a smoke run)")
    ap.add_argument("--json", help="also write the figures to this JSON file")
    ap.add_argument("--no-compare", action="store_true", help="denavit only")
    ap.add_argument("--ik-one-attempt", action="store_true", help="only the table of IK with one attempt")
    ap.add_argument(
        "--ik-targets", type=int, help="targets per robot of the IK one-attempt table (default 500, 100 with --quick)"
    )
    args = ap.parse_args()
    rep = 5 if args.quick else 21
    have_rtb = rtb is not None and not args.no_compare
    have_pin = pin is not None and not args.no_compare
    versions = (
        f"denavit {dv.__version__}"
        + (f", roboticstoolbox {rtb.__version__}" if have_rtb else "")
        + (f", pinocchio {pin.__version__}" if have_pin else "")
        + f"; {os.cpu_count()} cores; medians"
    )
    urdf = os.path.join(os.path.dirname(__file__), "..", "tests", "data", "urdf", "panda_style.urdf")
    arms7 = [("panda_style.urdf (7 joints)", dv.load_model(urdf)), ("iiwa14 (7 joints)", iiwa14())]
    chains = [(n, dv.load_model(n)) for n in ("kr5", "ur5", "puma560", "tiansui_mdh")] + arms7
    n_one = args.ik_targets or (100 if args.quick else 500)
    if args.ik_one_attempt:
        print(versions)
        one = ik_one_attempt(chains, n_one, have_rtb, have_pin) + ik_one_attempt(
            arms7, n_one, have_rtb, have_pin, respect_limits=False
        )
        print_one_attempt(one, have_rtb)
        return

    mdh, edh = dv.load_model("tiansui_mdh"), dv.load_model("tiansui_edh")
    rows = []  # (case, denavit, rtb, pinocchio, target)
    fig = {}

    def ms(s):
        return f"{s * 1e3:.3f} ms"

    def us(s):
        return f"{s * 1e6:.2f} us"

    # 1. Guo trajectory
    T0, targets = guo_targets()
    branch = np.radians([28.65, 30, 100, 50, -1.37, 28.65])
    for name, m in (("MDH", mdh), ("ED-H", edh)):
        start = dv.ik(m, T0, branch, method="newton", restarts=0).q
        for method in ("newton", "lm"):
            res = dv.ik_path(m, targets, start, method=method)
            ok = bool(res.success.all())
            t = once(lambda m=m, start=start, method=method: dv.ik_path(m, targets, start, method=method), rep * 4)
            fig[f"guo_{name}_{method}"] = t
            r_txt = p_txt = "-"
            if name == "MDH" and method == "lm" and have_rtb:
                robot = rtb_robot(m)

                def rtb_path(start=start, robot=robot):
                    q, sols = start, []
                    for T in targets:
                        s = robot.ik_LM(T, q0=q, tol=1e-20, ilimit=30, slimit=1)
                        q = s.q
                        sols.append(q)
                    return sols

                sols = rtb_path()
                worst = max(max(pose_error(dv.fk(m, q), T)) for q, T in zip(sols, targets))
                t_r = once(rtb_path, max(3, rep // 2))
                fig["guo_rtb"] = t_r
                r_txt = f"{ms(t_r)} (ik_LM, worst error {worst:.1e})"
            if name == "MDH" and method == "lm" and have_pin:
                pm, pd, jid = pin_model(m)

                def pin_path(start=start, pm=pm, pd=pd, jid=jid):
                    q, sols = start, []
                    for T in targets:
                        q = pin_ik(pm, pd, jid, T, q, tol=1e-10)
                        sols.append(q)
                    return sols

                sols = pin_path()
                worst = max(max(pose_error(dv.fk(m, q), T)) for q, T in zip(sols, targets))
                t_p = once(pin_path, max(3, rep // 2))
                fig["guo_pin"] = t_p
                p_txt = f"{ms(t_p)} (CLIK loop, worst error {worst:.1e})"
            worst = max(res.position_error.max(), res.rotation_error.max())
            rows.append(
                (
                    (
                        f"Guo trajectory {name}, {method}: 100 warm-started solves, tol 1e-10 "
                        f"({'all solved' if ok else 'FAILURES'}, worst error {worst:.1e})"
                    ),
                    ms(t),
                    r_txt,
                    p_txt,
                    "<= 0.3 ms total (paper 0.456 s MDH / 0.504 s ED-H)",
                )
            )

    # 2. single FK, 3. single Jacobian
    q = np.array([0.3, -0.2, 0.5, 0.1, 0.4, -0.3])
    n_call = 2000 if args.quick else 20000
    t_fk = per_call(lambda: dv.fk(mdh, q), n_call, rep)
    t_j = per_call(lambda: dv.jacobian(mdh, q), n_call, rep)
    fig["fk"], fig["jacobian"] = t_fk, t_j
    r_fk = r_j = p_fk = p_j = "-"
    if have_rtb:
        robot = rtb_robot(mdh)
        ets = robot.ets()
        r_fk = us(per_call(lambda: ets.fkine(q), n_call // 10, rep))
        r_j = us(per_call(lambda: ets.jacob0(q), n_call // 10, rep))
    if have_pin:
        pm, pd, jid = pin_model(mdh)
        p_fk = us(per_call(lambda: pin.forwardKinematics(pm, pd, q), n_call, rep)) + " (no array returned)"
        p_j = us(per_call(lambda: pin.computeJointJacobian(pm, pd, q, jid), n_call, rep)) + " (joint frame)"
    rows.append(("single FK call from Python (returns the 4x4 array)", us(t_fk), r_fk, p_fk, "<= 0.7 us"))
    rows.append(("single Jacobian call (6 x n, world frame)", us(t_j), r_j, p_j, "<= 0.8 us"))

    # 4. batch FK
    N = 100_000
    qs = np.random.default_rng(0).uniform(-np.pi, np.pi, (N, 6))
    t_b = once(lambda: dv.fk_batch(mdh, qs), rep)
    fig["fk_batch_100k"] = t_b
    P, off = mdh.placements, np.array(mdh.offsets)

    def numpy_fk(qs):
        T = np.broadcast_to(np.eye(4), (len(qs), 4, 4)).copy()
        c, s = np.cos(qs + off), np.sin(qs + off)
        for i in range(6):
            R = np.zeros((len(qs), 4, 4))
            R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1] = c[:, i], -s[:, i], s[:, i], c[:, i]
            R[:, 2, 2] = R[:, 3, 3] = 1
            T = T @ P[i] @ R
        return T

    assert np.allclose(numpy_fk(qs[:10]), dv.fk_batch(mdh, qs[:10]), atol=1e-12)
    t_np = once(lambda: numpy_fk(qs), max(3, rep // 3))
    r_b = "-"
    if have_rtb:
        ets = rtb_robot(mdh).ets()
        r_b = ms(once(lambda: ets.fkine(qs), max(3, rep // 3)))
    rows.append((f"batch FK, {N:,} configurations (numpy vectorised: {ms(t_np)})", ms(t_b), r_b, "-", "<= 5 ms"))

    # 5. IK of random reachable targets
    n_ik = 200 if args.quick else 1000
    rng = np.random.default_rng(42)
    qt = rng.uniform(-np.pi, np.pi, (n_ik, 6))
    Ts = dv.fk_batch(mdh, qt)
    q0 = np.full(6, 0.3)
    times, ok = [], 0
    for T in Ts:
        t = time.perf_counter()
        r = dv.ik(mdh, T, q0, tol_position=1e-9, tol_rotation=1e-9)
        times.append(time.perf_counter() - t)
        e = pose_error(dv.fk(mdh, r.q), T)
        ok += r.success and max(e) <= 1e-9 + 1e-15
    fig["ik_median"], fig["ik_success"] = float(np.median(times)), ok / n_ik
    t_batch = once(lambda: dv.ik_batch(mdh, Ts, q0, tol_position=1e-9, tol_rotation=1e-9), max(3, rep // 3))
    d_txt = f"{us(np.median(times))} median, {100 * ok / n_ik:.1f} % (ik_batch: {us(t_batch / n_ik)} per target)"
    r_txt = p_txt = "-"
    if have_rtb:
        robot = rtb_robot(mdh)
        rt, rok = [], 0
        for T in Ts[: n_ik // 2]:
            t = time.perf_counter()
            s = robot.ik_LM(T, q0=q0, tol=1e-20, ilimit=30, slimit=100)
            rt.append(time.perf_counter() - t)
            rok += max(pose_error(dv.fk(mdh, s.q), T)) <= 1e-9
        r_txt = f"{us(np.median(rt))} median, {100 * rok / len(rt):.1f} % (ik_LM, {len(rt)} targets)"
    if have_pin:
        pm, pd, jid = pin_model(mdh)
        pt, pok = [], 0
        for T in Ts[: n_ik // 5]:
            t = time.perf_counter()
            qp = pin_ik(pm, pd, jid, T, q0)
            pt.append(time.perf_counter() - t)
            pok += max(pose_error(dv.fk(mdh, qp), T)) <= 1e-9
        p_txt = f"{us(np.median(pt))} median, {100 * pok / len(pt):.1f} % (CLIK, no restarts, {len(pt)} targets)"
    rows.append(
        (
            f"IK, {n_ik} random reachable targets from q0 = 0.3 rad, pose error <= 1e-9",
            d_txt,
            r_txt,
            p_txt,
            "<= 10 us median, >= 99.9 %",
        )
    )

    # 6. IK, one attempt
    one = ik_one_attempt(chains, n_one, have_rtb, have_pin) + ik_one_attempt(
        arms7, n_one, have_rtb, have_pin, respect_limits=False
    )

    # the tables
    head = (
        "case",
        "denavit",
        "roboticstoolbox" + ("" if have_rtb else " (not installed)"),
        "pinocchio" + ("" if have_pin else " (not installed)"),
        "target",
    )
    print(versions)
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print("| " + " | ".join(r) + " |")
    print()
    print_one_attempt(one, have_rtb)
    fig["ik_one_attempt"] = {r[0]: r[1:] for r in one}
    if args.json:
        with open(args.json, "w") as f:
            json.dump(fig, f, indent=2)


if __name__ == "__main__":
    main()
