"""A recording's segmentation as text in the user's units (``denavit inspect``, identify's notes)."""

from __future__ import annotations

import math

from ..units import angle_scale


def segmentation_table(seg, angle: str = "deg") -> str:
    """The motions of a :class:`denavit.recording.Segmentation` as a table the user can check (times in s, joint
    values in ``angle`` / mm)."""
    a = angle_scale(angle)
    lines = [
        (
            f"segmentation of {seg.source} ({seg.method}): {len(seg.sweeps)} sweeps, {len(seg.segments)} motions,"
            f" {seg.dwell_rows} dwell rows excluded"
        ),
        (
            f"{'#':>3} {'joint':>5} {'role':<8} {'rows':>13} {'time (s)':>19} {'from':>10} {'to':>10} {'arc':>9}"
            f" {'points':>7}"
        ),
    ]
    for k, s in enumerate(seg.segments, 1):
        prism = seg.kinds is not None and seg.kinds[s.joint - 1] == "prismatic"
        sc = 1e3 if prism else 1.0 / a
        fr = f"{s.q_from * sc:.3f}" if math.isfinite(s.q_from) else "-"
        to = f"{s.q_to * sc:.3f}" if math.isfinite(s.q_to) else "-"
        arc = f"{math.degrees(s.arc):.2f}" if math.isfinite(s.arc) else "-"
        lines.append(
            f"{k:>3} {s.joint:>5} {s.role:<8} {f'{s.start + 1}-{s.stop}':>13} {f'{s.t_start:.3f}-{s.t_stop:.3f}':>19}"
            f" {fr:>10} {to:>10} {arc:>9} {s.stop - s.start:>7}"
        )
    lines.append(
        f"(joint values in {angle}, mm for prismatic joints; arc in deg; rows 1-based; dwell excluded from every"
        " motion)"
    )
    return "\n".join(lines)
