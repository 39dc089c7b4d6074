"""The one exception type qmesh raises for bad input."""


class QmeshError(ValueError, TypeError):
    """Bad input to qmesh: a non-SPD conductivity, a bad domain, a wrong-typed option, an unreadable file…

    Every message names the argument (or file) at fault and the value received. It subclasses
    both ValueError and TypeError, so `except ValueError` and `except TypeError` catch it too:
    a wrong value and a wrong type are reported alike.
    """
