"""The package's exception types (one hierarchy; every message says what was expected, what came, and where).

An error of the Rust core reaches Python as a :class:`DenavitError` (or a subclass) whose attributes carry the
core error's fields, so callers read ``e.expected`` / ``e.got`` / ``e.joint`` instead of parsing the message.
``kind`` names the core variant:

=================  ==========================================================  =====================
kind               attributes set (others are None)                            class
=================  ==========================================================  =====================
SizeMismatch       what, expected (int), got (int)                             DenavitError
NonFinite          what, index (flat index), value                             DenavitError
Overflow           what (the result), at ("joint 2"), value, cause             DenavitError
NotSe3             what, reason                                                DenavitError
InvalidArgument    what, expected (str), got (str)                             DenavitError
Degenerate         reason                                                      DegenerateError
UnknownName        what (the kind of name, e.g. "convention"), got, expected   DenavitError
NotConverged       iterations, position_error (m), rotation_error (rad)        NotConvergedError
=================  ==========================================================  =====================

``joint`` (1-based) is set where the binding knows which joint or link the error is about (e.g.
``Model.with_inertias``). Errors raised by the Python layer itself have ``kind`` None.

Every message is one line of at most :data:`MAX_MESSAGE` characters: line breaks become spaces, and a longer
message (one that echoes a 250 kB header, say) keeps its head (where, what was expected) and its tail (the
hint) around an elision mark, so a user reads it whole on any terminal or log.
"""

import operator
import re

#: The longest message, in characters: room for a long path and a long explanation; an echo of a 250 kB
#: header is cut to it.
MAX_MESSAGE = 500
_ELIDED = " [...] "

_FIELDS = (
    "what",
    "expected",
    "got",
    "index",
    "value",
    "reason",
    "iterations",
    "position_error",
    "rotation_error",
    "at",
    "cause",
    "joint",
)


def readable(message: str) -> str:
    """``message`` on one line (each line break, with the blanks around it, as one space), at most
    :data:`MAX_MESSAGE` characters: a longer one keeps its first two thirds and its last third around an
    elision mark."""
    text = re.sub(r"[ \t]*[\r\n]+[ \t]*", " ", str(message))
    if len(text) <= MAX_MESSAGE:
        return text
    room = MAX_MESSAGE - len(_ELIDED)
    head = 2 * room // 3
    return text[:head] + _ELIDED + text[len(text) - (room - head) :]


def _rebuild(cls, message, kind, fields):
    return cls(message, kind=kind, **fields)


class DenavitError(ValueError):
    """Base class of every error raised by denavit; see the module docstring for the attributes."""

    def __init__(self, message="", *, kind=None, **fields):
        unknown = sorted(set(fields) - set(_FIELDS))
        if unknown:
            raise TypeError(f"{type(self).__name__}: unknown fields {unknown}, expected some of {list(_FIELDS)}")
        super().__init__(readable(message))
        self.kind = kind
        for name in _FIELDS:
            setattr(self, name, fields.get(name))

    def __reduce__(self):
        # the fields are keyword-only: pickle (multiprocessing, joblib) would drop them with the default reduce
        message = self.args[0] if self.args else ""
        return _rebuild, (type(self), message, self.kind, {name: getattr(self, name) for name in _FIELDS})


class NotConvergedError(DenavitError):
    """An iterative solver stopped before meeting its tolerance."""


class DegenerateError(DenavitError):
    """Input geometry is degenerate (collinear points, zero-length axis, too-short arc, ...)."""


class DenavitWarning(UserWarning):
    """Input that denavit can use only in part (e.g. a URDF whose inertials are not physical)."""


def check_seed(seed) -> int:
    """``seed`` as the seed of a random generator: an integer >= 0 (as the core's IK takes), else the one-line
    :class:`DenavitError` (numpy's own error for a negative seed had reached users as an internal error)."""
    try:
        value = None if isinstance(seed, bool) else operator.index(seed)
    except TypeError:
        value = None
    if value is None or value < 0:
        raise DenavitError(f"invalid seed: expected an integer >= 0, got {seed!r}")
    return value
