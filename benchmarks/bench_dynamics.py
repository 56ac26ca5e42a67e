"""Speed of the dynamics from Python: denavit vs pinocchio vs roboticstoolbox (each when importable).

TianSui-One (Guo et al. Table I, modified DH) with the illustrative inertials of the tests (given in its ED-H
frames, re-expressed in the MD-H frames), the same robot in every library; the script first checks that the
three give the same torques. Reports the median over many repeats (time.perf_counter_ns) of

* one inverse-dynamics call (RNE) with numpy arrays in and out,
* one mass matrix (CRBA; pinocchio's upper triangle only, as it returns it),
* one forward-dynamics call (ABA),
* inverse dynamics of a batch of N states (default 100,000): denavit's rnea_batch (all cores, GIL released);
  pinocchio and roboticstoolbox loop over the rows (rtb's C `rne` takes the whole (N, n) array at once).

Run: `python benchmarks/bench_dynamics.py [--states 100000] [--repeats 31]`. Targets of issue #4 on the 2-core
development machine: RNE <= 1.2 us, mass matrix <= 1.5 us, batch RNE of 100,000 states <= 20 ms.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

import denavit as dv
from denavit import _core

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
G = np.array([0.0, 0.0, -9.81])


def tiansui():
    """TianSui-One in MD-H frames, with the tests' illustrative inertials (given in the ED-H frames)."""
    from test_dynamics import tiansui_edh  # noqa: PLC0415

    return _core.transfer_inertias(tiansui_edh(), dv.load_model("tiansui_mdh"))


def per_call_ns(fn, calls: int, repeats: int) -> float:
    """Median over `repeats` of the mean time of `calls` back-to-back calls, in ns."""
    fn()
    samples = []
    for _ in range(repeats):
        t = time.perf_counter_ns()
        for _ in range(calls):
            fn()
        samples.append((time.perf_counter_ns() - t) / calls)
    return statistics.median(samples)


def once_ns(fn, repeats: int) -> float:
    fn()
    samples = []
    for _ in range(repeats):
        t = time.perf_counter_ns()
        fn()
        samples.append(time.perf_counter_ns() - t)
    return statistics.median(samples)


def pinocchio_model(model):
    import pinocchio as pin  # noqa: PLC0415

    pm = pin.Model()
    parent = 0
    ins = model.inertias
    for i, kind in enumerate(model.kinds):
        M = model.T_world_base @ model.placements[0] if i == 0 else model.placements[i]
        joint = pin.JointModelRZ() if kind == "revolute" else pin.JointModelPZ()
        parent = pm.addJoint(parent, joint, pin.SE3(M[:3, :3], M[:3, 3]), model.names[i])
        pm.appendBodyToJoint(
            parent, pin.Inertia(ins["masses"][i], ins["coms"][i], ins["inertias"][i]), pin.SE3.Identity()
        )
    pm.gravity = pin.Motion(G, np.zeros(3))
    return pin, pm


def rtb_model(model):
    """The MD-H table as a roboticstoolbox DHRobot (modified DH) with the same inertials."""
    import roboticstoolbox as rtb  # noqa: PLC0415

    table = dv.load_robot("tiansui_mdh").table.params  # alpha, a, theta, d
    ins = model.inertias
    links = [
        rtb.RevoluteMDH(
            alpha=al,
            a=a,
            offset=th,
            d=d,
            m=ins["masses"][i],
            r=ins["coms"][i],
            I=ins["inertias"][i],
            G=1,
            Jm=0,
            B=0,
            Tc=[0, 0],
        )
        for i, (al, a, th, d) in enumerate(table)
    ]
    robot = rtb.DHRobot(links, name="tiansui_mdh", gravity=G)
    return robot


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--states", type=int, default=100_000)
    ap.add_argument("--repeats", type=int, default=31)
    ap.add_argument("--calls", type=int, default=2000, help="calls per timed block of the single-call rows")
    args = ap.parse_args()
    model = tiansui()
    n = model.nq
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-2, 2, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    qs, qds, qdds = (
        rng.uniform(-2, 2, (args.states, n)),
        rng.uniform(-1, 1, (args.states, n)),
        rng.uniform(-1, 1, (args.states, n)),
    )
    tau = _core.rnea(model, q, qd, qdd)
    rows: dict[str, dict[str, float]] = {}
    R, C = args.repeats, args.calls

    rows["denavit"] = {
        "rnea": per_call_ns(lambda: _core.rnea(model, q, qd, qdd), C, R),
        "mass matrix": per_call_ns(lambda: _core.mass_matrix(model, q), C, R),
        "aba": per_call_ns(lambda: _core.forward_dynamics(model, q, qd, tau), C, R),
        "batch rnea": once_ns(lambda: _core.rnea_batch(model, qs, qds, qdds), R),
    }
    notes = []
    try:
        pin, pm = pinocchio_model(model)
        pd = pm.createData()
        off = np.array(model.offsets)
        qp, qps = q + off, qs + off
        err = np.abs(pin.rnea(pm, pd, qp, qd, qdd) - tau).max()
        notes.append(f"pinocchio {pin.__version__}: max |tau difference| {err:.1e} N m")

        def pin_batch():
            for k in range(len(qps)):
                pin.rnea(pm, pd, qps[k], qds[k], qdds[k])

        rows["pinocchio"] = {
            "rnea": per_call_ns(lambda: pin.rnea(pm, pd, qp, qd, qdd), C, R),
            "mass matrix": per_call_ns(lambda: pin.crba(pm, pd, qp), C, R),
            "aba": per_call_ns(lambda: pin.aba(pm, pd, qp, qd, tau), C, R),
            "batch rnea": once_ns(pin_batch, max(3, R // 10)),
        }
    except ImportError:
        notes.append("pinocchio not importable (pip install pin)")
    try:
        robot = rtb_model(model)
        import roboticstoolbox as rtb  # noqa: PLC0415

        err = np.abs(np.asarray(robot.rne(q, qd, qdd)) - tau).max()
        notes.append(f"roboticstoolbox {rtb.__version__}: max |tau difference| {err:.1e} N m")
        rows["roboticstoolbox"] = {
            "rnea": per_call_ns(lambda: robot.rne(q, qd, qdd), max(50, C // 20), R),
            "mass matrix": per_call_ns(lambda: robot.inertia(q), max(50, C // 20), R),
            "aba": per_call_ns(lambda: robot.accel(q, qd, tau), max(20, C // 50), R),
            "batch rnea": once_ns(lambda: robot.rne(qs, qds, qdds), 3),
        }
    except ImportError:
        notes.append("roboticstoolbox not importable (pip install roboticstoolbox-python)")

    cols = ["rnea", "mass matrix", "aba", "batch rnea"]
    units = {"rnea": 1e3, "mass matrix": 1e3, "aba": 1e3, "batch rnea": 1e6}
    print(
        f"TianSui-One (6 revolute joints), median of {R} repeats; single calls in us, batch of {args.states:,} states"
        f" in ms; {os.cpu_count()} cores"
    )
    print(f"{'library':<18}" + "".join(f"{c + (' (ms)' if c == 'batch rnea' else ' (us)'):>18}" for c in cols))
    for lib, r in rows.items():
        print(f"{lib:<18}" + "".join(f"{r[c] / units[c]:>18.3f}" for c in cols))
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
