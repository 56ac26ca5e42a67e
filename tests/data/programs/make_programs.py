"""Write the example programs of this directory (README.md): each a faithful minimal program in its controller's
documented syntax, its positions spread over the workspace of a built-in model (the KR5 for KRL, RAPID and TP, the
UR5 for URScript), its configurations those of the joint values it was made from. Run from the repository root:
``python tests/data/programs/make_programs.py`` (deterministic; the files are committed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import denavit as dv
from denavit.io.programs import abb, fanuc, kuka
from denavit.io.programs.rotations import matrix_quaternion, matrix_zyx
from denavit.io.robots import load

HERE = Path(__file__).parent


def workspace(robot, count, seed, lower_z=0.15):
    """``count`` configurations over 0.85 of the joint limits, the tool above ``lower_z`` (m), 15 deg clear of the
    wrist singularity (q5 = 0) and of the stretched or folded arm, as a taught program is."""
    m = robot.model()
    rng = np.random.default_rng(seed)
    lo, hi = np.asarray(m.lower), np.asarray(m.upper)
    lo, hi = np.maximum(lo, -2 * np.pi), np.minimum(hi, 2 * np.pi)
    out = []
    while len(out) < count:
        q = rng.uniform(lo, hi) * 0.85
        T = dv.fk(m, q)
        if T[2, 3] < lower_z or abs(np.sin(q[4])) < np.sin(np.radians(15)):
            continue
        if robot.name == "kr5" and abs(np.sin(q[2] - np.arctan2(0.12, 0.62))) < np.sin(np.radians(15)):
            continue
        if robot.name == "ur5" and abs(np.sin(q[2])) < np.sin(np.radians(15)):
            continue
        out.append(q)
    return np.array(out)


def tp(v: float) -> str:
    """A number as FANUC's controller writes it in an .ls: 3 decimals, no leading zero ('.002', '-.000'), width 9."""
    s = f"{v:.3f}"
    s = s[:-5] + s[-4:] if s.lstrip("-").startswith("0.") else s
    return s.rjust(9)


def kuka_programs():
    r = load("kr5")
    m = r.model()
    Q = workspace(r, 16, 1)
    F = np.eye(4)
    F[:3, :3] = kuka.flange_rotation(r)
    cache = {"signs": kuka.signs(r)}
    for stem, tool_no in (("kr5_demo", 0), ("kr5_tool", 1)):
        tool = np.eye(4)
        base = np.eye(4)
        if tool_no:
            tool[:3, 3] = [0.185, 0.0, 0.095]  # a torch: 185 mm along the flange's x (out of it), 95 mm up
            tool[:3, :3] = kuka.rot("y", np.radians(-30))
            base[:3, 3] = [0.6, -0.2, 0.1]
            base[:3, :3] = kuka.rot("z", np.radians(15))
        dat = [
            "&ACCESS RVP",
            "&REL 4",
            "&PARAM TEMPLATE = C:\\KRC\\Roboter\\Template\\vorgabe",
            "&PARAM EDITMASK = *",
            f"DEFDAT  {stem.upper()}",
            ";FOLD EXTERNAL DECLARATIONS;%{PE}%V3.2.0,%MKUKATPBASIS,%CEXT,%VCOMMON,%P",
            ";FOLD BASISTECH EXT;%{PE}%V3.2.0,%MKUKATPBASIS,%CEXT,%VEXT,%P",
            "EXT  BAS (BAS_COMMAND  :IN,REAL  :IN )",
            "DECL INT SUCCESS",
            ";ENDFOLD (BASISTECH EXT)",
            ";ENDFOLD (EXTERNAL DECLARATIONS)",
            "",
        ]
        src = [
            "&ACCESS RVP",
            "&REL 4",
            "&PARAM TEMPLATE = C:\\KRC\\Roboter\\Template\\vorgabe",
            "&PARAM EDITMASK = *",
            f"DEF {stem.upper()}( )",
            ";FOLD INI;%{PE}",
            "  ;FOLD BASISTECH INI",
            "    GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )",
            "    INTERRUPT ON 3",
            "    BAS (#INITMOV,0 )",
            "  ;ENDFOLD (BASISTECH INI)",
            ";ENDFOLD (INI)",
            "",
            ";FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME, 3:, 5:100, 7:DEFAULT",
            "$BWDSTART = FALSE",
            "PDAT_ACT=PDEFAULT",
            "FDAT_ACT=FHOME",
            "BAS (#PTP_PARAMS,100 )",
            "$H_POS=XHOME",
            "PTP  XHOME",
            ";ENDFOLD",
            "",
        ]
        for i, q in enumerate(Q, 1):
            T = np.linalg.inv(base) @ dv.fk(m, q) @ F @ tool
            S, Tt = kuka.configuration(m, q, cache)
            if i % 4 == 0:
                a = np.degrees(q * kuka.signs(r))
                dat.append(
                    f"DECL E6AXIS XP{i}={{A1 {a[0]:.5f},A2 {a[1]:.5f},A3 {a[2]:.5f},A4 {a[3]:.5f},A5 {a[4]:.5f},A6"
                    f" {a[5]:.5f},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}"
                )
            else:
                p, abc = T[:3, 3] * 1e3, np.degrees(matrix_zyx(T[:3, :3]))
                dat.append(
                    f"DECL E6POS XP{i}={{X {p[0]:.4f},Y {p[1]:.4f},Z {p[2]:.4f},A {abc[0]:.4f},B {abc[1]:.4f},C"
                    f" {abc[2]:.4f},S {S},T {Tt},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}"
                )
            dat.append(
                f'DECL FDAT FP{i}={{TOOL_NO {tool_no},BASE_NO {tool_no},IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}}'
            )
            dat.append(
                f"DECL {'P' if i % 2 else 'L'}DAT {'P' if i % 2 else 'L'}PDAT{i}={{VEL"
                f" {'100.0' if i % 2 else '2.0'},ACC 100.0,APO_DIST 100.0,APO_MODE #CDIS}}"
            )
            motion = "PTP" if i % 2 or i % 4 == 0 else "LIN"
            src += [
                (
                    f";FOLD {motion} P{i} CONT Vel={'100 %' if motion == 'PTP' else '2 m/s'}"
                    f" {'P' if i % 2 else 'L'}PDAT{i} Tool[{tool_no}] Base[{tool_no}];%{{PE}}%R"
                    f" 8.3.44,%MKUKATPBASIS,%CMOVE,%V{motion},%P 1:{motion}, 2:P{i}, 3:C_DIS, 5:100,"
                    f" 7:{'P' if i % 2 else 'L'}PDAT{i}"
                ),
                "$BWDSTART=FALSE",
                f"{'P' if i % 2 else 'L'}DAT_ACT={'P' if i % 2 else 'L'}PDAT{i}",
                f"FDAT_ACT=FP{i}",
                f"BAS(#{'PTP' if motion == 'PTP' else 'CP'}_PARAMS,{'100' if motion == 'PTP' else '2'})",
                f"{motion} XP{i} C_DIS",
                ";ENDFOLD",
            ]
        dat += ["ENDDAT", ""]
        src += [
            "",
            ";FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME, 3:, 5:100, 7:DEFAULT",
            "$BWDSTART = FALSE",
            "PDAT_ACT=PDEFAULT",
            "FDAT_ACT=FHOME",
            "BAS (#PTP_PARAMS,100 )",
            "$H_POS=XHOME",
            "PTP  XHOME",
            ";ENDFOLD",
            "",
            "END",
            "",
        ]
        d = HERE / "kuka"
        d.mkdir(exist_ok=True)
        (d / f"{stem}.dat").write_bytes("\r\n".join(dat).encode())
        (d / f"{stem}.src").write_bytes("\r\n".join(src).encode())
        if tool_no:
            t_abc, b_abc = np.degrees(matrix_zyx(tool[:3, :3])), np.degrees(matrix_zyx(base[:3, :3]))
            (d / "$config.dat").write_bytes(
                "\r\n".join(
                    [
                        "&ACCESS RVO",
                        "DEFDAT  $CONFIG",
                        "",
                        ";FOLD TOOL/BASE DATA (an excerpt: the frames kr5_tool uses)",
                        (
                            f"TOOL_DATA[1]={{X {tool[0, 3] * 1e3:.3f},Y {tool[1, 3] * 1e3:.3f},Z"
                            f" {tool[2, 3] * 1e3:.3f},A {t_abc[0]:.4f},B {t_abc[1]:.4f},C {t_abc[2]:.4f}}}"
                        ),
                        (
                            f"BASE_DATA[1]={{X {base[0, 3] * 1e3:.3f},Y {base[1, 3] * 1e3:.3f},Z"
                            f" {base[2, 3] * 1e3:.3f},A {b_abc[0]:.4f},B {b_abc[1]:.4f},C {b_abc[2]:.4f}}}"
                        ),
                        ";ENDFOLD",
                        "",
                        "ENDDAT",
                        "",
                    ]
                ).encode()
            )


def abb_program():
    r = load("kr5")
    m = r.model()
    Q = workspace(r, 16, 2)
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.02, 0.15]
    tool[:3, :3] = kuka.rot("x", np.radians(10))
    wobj = np.eye(4)
    wobj[:3, 3] = [0.4, 0.1, 0.05]
    wobj[:3, :3] = kuka.rot("z", np.radians(-20))
    cache = {"signs": abb.signs(r)}
    tq, wq = matrix_quaternion(tool[:3, :3]), matrix_quaternion(wobj[:3, :3])
    lines = [
        "%%%",
        "  VERSION:1",
        "  LANGUAGE:ENGLISH",
        "%%%",
        "",
        "MODULE DemoKR5",
        "  ! positions over the KR5's workspace, see README.md",
        (
            "  PERS tooldata"
            f" tGripper:=[TRUE,[[{tool[0, 3] * 1e3:.1f},{tool[1, 3] * 1e3:.1f},{tool[2, 3] * 1e3:.1f}],[{tq[0]:.7f}"
            f",{tq[1]:.7f},{tq[2]:.7f},{tq[3]:.7f}]],"
            "[1.5,[0,0,80],[1,0,0,0],0,0,0]];"
        ),
        (
            "  TASK PERS wobjdata"
            f' wTable:=[FALSE,TRUE,"",[[{wobj[0, 3] * 1e3:.1f},{wobj[1, 3] * 1e3:.1f},{wobj[2, 3] * 1e3:.1f}'
            f"],[{wq[0]:.7f},{wq[1]:.7f},{wq[2]:.7f},{wq[3]:.7f}]],"
            "[[0,0,0],[1,0,0,0]]];"
        ),
    ]
    body = ["", "  PROC main()", "    ConfJ \\On;", "    ConfL \\On;"]
    for i, q in enumerate(Q, 1):
        cf = abb.configuration(m, q, cache)
        use_tool = i % 3 != 0
        T = dv.fk(m, q) @ (tool if use_tool else np.eye(4))
        if use_tool:
            T = np.linalg.inv(wobj) @ T
        p, qu = T[:3, 3] * 1e3, matrix_quaternion(T[:3, :3])
        lit = (
            f"[[{p[0]:.2f},{p[1]:.2f},{p[2]:.2f}],[{qu[0]:.8f},{qu[1]:.8f},{qu[2]:.8f},{qu[3]:.8f}],"
            f"[{cf[0]},{cf[1]},{cf[2]},{cf[3]}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
        )
        frames = "tGripper\\WObj:=wTable" if use_tool else "tool0"
        if i % 5 == 0:
            a = np.degrees(q)
            lines.append(
                "  CONST jointtarget"
                f" jpos{i}:=[[{a[0]:.4f},{a[1]:.4f},{a[2]:.4f},{a[3]:.4f},{a[4]:.4f},{a[5]:.4f}"
                f"],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];"
            )
            body.append(f"    MoveAbsJ jpos{i}\\NoEOffs, v1000, z50, {frames};")
        elif i % 4 == 0:
            body.append(f"    MoveL {lit}, v500, z10, {frames};")
        else:
            lines.append(f"  CONST robtarget p{i * 10}:={lit};")
            body.append(
                f"    Move{'J' if i % 2 else 'L'} p{i * 10}, v{'1000' if i % 2 else '500'},"
                f" {'z50' if i % 2 else 'fine'}, {frames};"
            )
    body += ["  ENDPROC", "ENDMODULE", ""]
    d = HERE / "abb"
    d.mkdir(exist_ok=True)
    (d / "DemoKR5.mod").write_bytes("\r\n".join(lines + body).encode())


def fanuc_program():
    r = load("kr5")
    m = r.model()
    Q = workspace(r, 16, 3)
    cache = {"signs": fanuc.signs(r)}
    mn, pos = [], []
    for i, q in enumerate(Q, 1):
        mn.append(
            f"{i:4d}:{'J' if i % 2 else 'L'} P[{i}] {'100%' if i % 2 else '500mm/sec'}"
            f" {'FINE' if i % 3 == 0 else 'CNT100'}    ;"
        )
        if i % 4 == 0:
            a = np.degrees(q)
            rows = [
                f"\tJ1= {tp(a[0])} deg,\tJ2= {tp(a[1])} deg,\tJ3= {tp(a[2])} deg,",
                f"\tJ4= {tp(a[3])} deg,\tJ5= {tp(a[4])} deg,\tJ6= {tp(a[5])} deg",
            ]
            pos += [f"P[{i}]{{", "   GP1:", "\tUF : 0, UT : 0,\t", *rows, "};"]
        else:
            T = dv.fk(m, q)
            p = T[:3, 3] * 1e3
            rr, pp, ww = np.degrees(matrix_zyx(T[:3, :3]))
            c = fanuc.configuration(m, q, cache)
            pos += [
                f"P[{i}]{{",
                "   GP1:",
                f"\tUF : 0, UT : 0,\t\tCONFIG : '{c[0]} {c[1]} {c[2]}, {c[3]}, {c[4]}, {c[5]}',",
                f"\tX = {tp(p[0])}  mm,\tY = {tp(p[1])}  mm,\tZ = {tp(p[2])}  mm,",
                f"\tW = {tp(ww)} deg,\tP = {tp(pp)} deg,\tR = {tp(rr)} deg",
                "};",
            ]
    head = [
        "/PROG  DEMO_KR5",
        "/ATTR",
        "OWNER\t\t= MNEDITOR;",
        'COMMENT\t\t= "workspace";',
        "PROG_SIZE\t= 0;",
        "CREATE\t\t= DATE 26-01-05  TIME 10:00:00;",
        "MODIFIED\t= DATE 26-01-05  TIME 10:00:00;",
        "FILE_NAME\t= ;",
        "VERSION\t\t= 0;",
        f"LINE_COUNT\t= {len(mn) + 2};",
        "MEMORY_SIZE\t= 0;",
        "PROTECT\t\t= READ_WRITE;",
        "TCD:  STACK_SIZE\t= 0,",
        "      TASK_PRIORITY\t= 50,",
        "      TIME_SLICE\t= 0,",
        "      BUSY_LAMP_OFF\t= 0,",
        "      ABORT_REQUEST\t= 0,",
        "      PAUSE_REQUEST\t= 0;",
        "DEFAULT_GROUP\t= 1,*,*,*,*;",
        "CONTROL_CODE\t= 00000000 00000000;",
        "/MN",
        "   1:  UFRAME_NUM=0 ;",
        "   2:  UTOOL_NUM=0 ;",
    ]
    mn = [f"{i + 2:4d}:{line[5:]}" for i, line in enumerate(mn, 1)]
    d = HERE / "fanuc"
    d.mkdir(exist_ok=True)
    (d / "demo_kr5.ls").write_bytes("\n".join(head + mn + ["/POS"] + pos + ["/END", ""]).encode())


def ur_program():
    r = load("ur5")
    m = r.model()
    rng = np.random.default_rng(4)
    # a path: joint moves to far-apart positions, each followed by linear moves near it (same branch)
    Q = workspace(r, 6, 4)
    tcp = np.eye(4)
    tcp[:3, 3] = [0.0, 0.0, 0.12]
    lines = [
        "def demo_ur5():",
        "  # positions over the UR5's workspace, see README.md",
        "  set_tcp(p[0.0, 0.0, 0.12, 0.0, 0.0, 0.0])",
        "  set_payload(1.0)",
        "  home = [0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]",
        "  movej(home, a=1.4, v=1.05)",
    ]
    from denavit.geometry import matrix_rotvec  # noqa: PLC0415

    k = 0
    for q in Q:
        lines.append(f"  movej([{', '.join(f'{v:.6f}' for v in q)}], a=1.4, v=1.05)")
        for _ in range(3):
            k += 1
            dq = rng.uniform(-0.25, 0.25, 6)
            while min(abs(np.sin((q + dq)[2])), abs(np.sin((q + dq)[4]))) < np.sin(np.radians(20)):
                dq = rng.uniform(-0.25, 0.25, 6)
            T = dv.fk(m, q + dq) @ tcp
            rv = matrix_rotvec(T[:3, :3][None])[0]
            vals = [*T[:3, 3], *rv]
            lit = (
                "p["
                + ", ".join(f"{v:.6f}".replace("0.", ".", 1) if abs(v) < 1 and k % 2 else f"{v:.6f}" for v in vals)
                + "]"
            )
            if k % 3 == 0:
                lines.append(f"  global wp{k} = {lit}")
                lines.append(f"  movel(wp{k}, a=1.2, v=0.25)")
            else:
                lines.append(f"  movel({lit}, a=1.2, v=0.25, r=0.01)")
    lines += ["  movej(home, a=1.4, v=1.05)", "end", "demo_ur5()", ""]
    d = HERE / "ur"
    d.mkdir(exist_ok=True)
    (d / "demo_ur5.script").write_bytes("\n".join(lines).encode())


if __name__ == "__main__":
    kuka_programs()
    abb_program()
    fanuc_program()
    ur_program()
