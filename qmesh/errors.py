"""The one exception type qmesh raises for bad input."""


class QmeshError(ValueError):
    """Bad input to qmesh: a non-SPD conductivity, a non-convex domain, an unreadable file…

    Subclasses ValueError so callers that already catch ValueError keep working.
    """


class QmeshWarning(UserWarning):
    """A mesh was made but cannot serve the request well (e.g. the domain is thinner than two
    elements in the metric); the message says what would help."""
