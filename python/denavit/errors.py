"""The package's exception types (one hierarchy; every message says what was expected, what came, and where)."""


class DenavitError(ValueError):
    """Base class of every error raised by denavit."""


class NotConvergedError(DenavitError):
    """An iterative solver stopped before meeting its tolerance."""


class DegenerateError(DenavitError):
    """Input geometry is degenerate (collinear points, zero-length axis, too-short arc, ...)."""


class DenavitWarning(UserWarning):
    """Input that denavit can use only in part (e.g. a URDF whose inertials are not physical)."""
