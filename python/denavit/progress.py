"""The progress of long jobs (:func:`denavit.identify`, :func:`denavit.calibrate`): their ``progress`` callback
hears each stage as a :class:`Stage`, a ``str`` (the message a one-argument callback such as ``list.append`` or
``print`` takes as it is) that carries the fraction of the work done before it."""

from __future__ import annotations


class Stage(str):
    """A stage of a long job: the message, with :attr:`fraction` (0 to 1) of the work done before it starts."""

    fraction: float

    def __new__(cls, message: str, fraction: float) -> Stage:
        stage = super().__new__(cls, message)
        stage.fraction = min(max(float(fraction), 0.0), 1.0)
        return stage
