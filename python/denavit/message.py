"""Messages with quantities (issue 35: a note says its lengths and angles in the user's units). A :class:`Message` is
a ``str`` (its text in mm and degrees, as the notes have always read, so code and tests that take strings take it)
that keeps its template and its quantities in SI, so the edge (the command line's ``--length`` / ``--angle``) can say
it again in other units with :meth:`Message.render`.

    >>> m = Message("the arm moved {d:.3g}, turned {a:.2g}", d=Length(0.0012), a=Angle(0.01))
    >>> str(m)
    'the arm moved 1.2 mm, turned 0.57 deg'
    >>> m.render((1.0, "m"), (1.0, "rad"))
    'the arm moved 0.0012 m, turned 0.01 rad'
"""

from __future__ import annotations

import math


class Length(float):
    """A length in metres, said in the message's length unit."""


class Angle(float):
    """An angle in radians, said in the message's angle unit."""


#: The units a message is written in unless the edge asks for others: (SI per unit, name).
MM = (1e-3, "mm")
DEG = (math.pi / 180.0, "deg")


class Message(str):
    """A message whose ``{name:spec}`` fields are :class:`Length` / :class:`Angle` quantities (SI) written in a
    length and an angle unit (the str itself: mm and deg), or other values written as they are."""

    template: str
    values: dict

    def __new__(cls, template: str, **values) -> Message:
        message = super().__new__(cls, _fill(template, values, MM, DEG))
        message.template, message.values = template, values
        return message

    def render(self, length: tuple[float, str] = MM, angle: tuple[float, str] = DEG) -> str:
        """The message in ``length`` / ``angle`` units, each given as (SI per unit, name), e.g. ``(1e-3, "mm")``."""
        return _fill(self.template, self.values, length, angle)


def _fill(template: str, values: dict, length: tuple[float, str], angle: tuple[float, str]) -> str:
    import string  # noqa: PLC0415

    out = []
    for text, field, spec, conv in string.Formatter().parse(template):
        out.append(text)
        if field is None:
            continue
        v = values[field]
        unit = length if isinstance(v, Length) else angle if isinstance(v, Angle) else None
        shown = float(v) / unit[0] if unit else v
        shown = format(shown if conv is None else (repr(shown) if conv == "r" else str(shown)), spec or "")
        out.append(f"{shown} {unit[1]}" if unit else shown)
    return "".join(out)


def render(text, length: tuple[float, str] = MM, angle: tuple[float, str] = DEG) -> str:
    """``text`` in ``length`` / ``angle`` units when it is a :class:`Message`, else as it is."""
    return text.render(length, angle) if isinstance(text, Message) else str(text)
