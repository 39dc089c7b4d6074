"""The one exception type qmesh raises for bad input."""


class QmeshError(ValueError):
    """Bad input to qmesh: a non-SPD conductivity, a non-convex domain, an unreadable file…

    Subclasses ValueError so callers that already catch ValueError keep working.
    """
