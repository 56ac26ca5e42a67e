"""KUKA RSI (RobotSensorInterface) XML records, logged one ``<Rob>`` telegram after another.

Format (KUKA.RobotSensorInterface 3.x/4.x, the robot's telegram to the sensor; the layout used by
ROS-Industrial's ``kuka_rsi_hw_interface``, ``rsi_state.h``, and KUKA's example ``RSI_Ethernet.xml``)::

    <Rob Type="KUKA">
      <RIst X="..." Y="..." Z="..." A="..." B="..." C="..."/>     actual Cartesian pose, mm and deg
      <RSol X="..." .../>                                        setpoint Cartesian pose
      <AIPos A1="..." A2="..." ... A6="..."/>                    actual axis positions, deg
      <ASPos A1="..." .../>                                      setpoint axis positions, deg
      <Delay D="0"/>
      <IPOC>123456</IPOC>                                        time stamp, ms
    </Rob>

A log is any text holding such records (with or without an enclosing element or an XML declaration per
record); each ``<Rob>`` element is one row, its line number the ``where``. ``A, B, C`` are KUKA's Euler
angles: ``R = Rz(A) Ry(B) Rx(C)``. Joint readings come from ``AIPos`` (``ASPos`` if asked for), the
Cartesian pose from ``RIst`` (``RSol`` if asked for).
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ...errors import DenavitError
from ..delimited import number
from ..text import read_text


def is_rsi(text: str) -> bool:
    return bool(re.search(r"<Rob\b", text)) and bool(re.search(r"<(AIPos|ASPos|RIst|RSol)\b", text))


def _attrs(el, names, where, tag):
    out = []
    for a in names:
        v = el.get(a)
        if v is None:
            raise DenavitError(f"{where}: <{tag}> lacks attribute {a}: expected {' '.join(names)}")
        out.append(number(v.strip(), where, f"<{tag} {a}=...>"))  # the one number rule of every reader
    return out


def _records(text: str, path):
    """(start, stop, line) of each ``<Rob ...>...</Rob>`` record, in one linear pass (a record without its
    closing tag before the next one opens is an error at its line)."""
    opens = [m.start() for m in re.finditer(r"<Rob\b", text)]
    line, at = 1, 0
    for k, s in enumerate(opens):
        line += text.count("\n", at, s)
        at = s
        e = text.find("</Rob>", s)
        nxt = opens[k + 1] if k + 1 < len(opens) else len(text)
        if e < 0 or e > nxt:
            raise DenavitError(f"{path}:{line}: a <Rob> record without its </Rob> before the next record")
        yield s, e + len("</Rob>"), line


def read(path: str | os.PathLike, *, text: str | None = None, axes: str = "AIPos", cartesian: str = "RIst"):
    """Read a KUKA RSI log: a Recording with time (IPOC, s), readings (rad) and the Cartesian poses (m)."""
    from ...geometry import rpy_matrix  # noqa: PLC0415
    from ...recording import Recording, check_time  # noqa: PLC0415

    path = Path(path)
    text = read_text(path, "recording", lines=True) if text is None else text
    t, q, T, where = [], [], [], []
    names = None
    for start, stop, ln in _records(text, path):
        w = f"{path}:{ln}"
        try:
            rob = ET.fromstring(text[start:stop])
        except ET.ParseError as e:
            raise DenavitError(f"{w}: not a well-formed <Rob> record: {e}") from None
        ipoc = rob.find(".//IPOC")
        if ipoc is None or not (ipoc.text or "").strip().lstrip("-").isdigit():
            raise DenavitError(f"{w}: <Rob> lacks <IPOC>: expected the time stamp in ms, e.g. <IPOC>123456</IPOC>")
        ax = rob.find(f".//{axes}")
        if ax is None:
            raise DenavitError(f"{w}: <Rob> lacks <{axes}>: expected the axis positions <{axes} A1=... A6=.../>")
        if names is None:
            names = sorted((a for a in ax.keys() if re.fullmatch(r"A\d+", a)), key=lambda a: int(a[1:]))
            if not names:
                raise DenavitError(f"{w}: <{axes}> has no A1, A2, ... attributes")
        q.append(_attrs(ax, names, w, axes))
        c = rob.find(f".//{cartesian}")
        if c is not None:
            x, y, z, a, b, cc = _attrs(c, ["X", "Y", "Z", "A", "B", "C"], w, cartesian)
            P = np.eye(4)
            P[:3, :3] = rpy_matrix(np.radians([cc, b, a]))  # R = Rz(A) Ry(B) Rx(C)
            P[:3, 3] = np.array([x, y, z]) * 1e-3
            T.append(P)
        elif T:
            raise DenavitError(f"{w}: <Rob> lacks <{cartesian}> which earlier records have")
        ms = number(ipoc.text.strip(), w, "<IPOC> (time stamp, ms)")
        t.append(ms * 1e-3)
        where.append(w)
    if not where:
        raise DenavitError(
            f'{path}: no <Rob> records: expected KUKA RSI telegrams <Rob Type="KUKA">...<IPOC>...</IPOC></Rob>'
        )
    if T and len(T) != len(where):
        raise DenavitError(f"{where[0]}: <Rob> lacks <{cartesian}> which later records have")
    t = np.array(t)
    check_time(t, where, "IPOC")
    poses = np.array(T) if T else None
    return Recording(
        t,
        np.radians(np.array(q)),
        None if poses is None else poses[:, None, :3, 3],
        where,
        str(path),
        "rsi",
        {"length": "mm", "angle": "deg", "time": "ms"},
        poses,
        ["revolute"] * len(names),
        notes=[
            f"{path}: RSI {axes} {names[0]}..{names[-1]}"
            + (f" and {cartesian}" if poses is not None else f" (no {cartesian})")
        ],
    )
