"""The one exception type qmesh raises for bad input."""


class QmeshError(ValueError, TypeError):
    """Bad input to qmesh: a non-SPD conductivity, a bad domain, a wrong-typed option, an unreadable file…

    A bad argument's message names the argument (or file) and shows the value received; an
    error found while meshing says what could not be done. It subclasses both ValueError and
    TypeError, so `except ValueError` and `except TypeError` catch it too: a wrong value and a
    wrong type are reported alike.
    """


class QmeshWarning(UserWarning):
    """A mesh was made but cannot serve the request well (e.g. the domain is thinner than two
    elements in the metric); the message says what would help."""
