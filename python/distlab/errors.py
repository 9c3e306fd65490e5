"""Exceptions of distlab: bad input names the offending field, as the CLI and the service do."""

import re

__all__ = ["InvalidInput", "InvalidInputType", "FieldUndefined", "invalid_input"]


class InvalidInput(ValueError):
    """Bad input. ``field`` is the path of the offending value (``"a.size[1]"``, ``"params.h"``;
    ``""`` for the request as a whole), as in the service's ``{"error": {"field"}}``."""

    def __init__(self, field: str, message: str):
        # A message that starts with its field (the C++ sweep's "sweep.values[2] = -1: …") is
        # not prefixed with it again.
        named = not field or (message.startswith(field) and message[len(field):len(field) + 1] in (" ", ":"))
        super().__init__(message if named else f"{field}: {message}")
        self.field = field
        self.message = message

    def __reduce__(self):
        # Pickled with both arguments (the default would call __init__ with the text alone): it
        # crosses processes as a Dask task's error (distlab.batch).
        return type(self), (self.field, self.message)


class InvalidInputType(InvalidInput, TypeError):
    """Bad input whose value has the wrong type (a string where a number belongs, ...): both a
    ValueError (as every InvalidInput) and a TypeError."""


class FieldUndefined(RuntimeError):
    """A Kelvin field's barrier row does not exist at this configuration: a control point is
    inside an object (h is defined outside only). Where σ > δ the safe set reaches the object's
    surface, so a controller that lets a point touch there must expect this and stop or back off;
    the message names the point and the field."""


# The JSON readers (backend/server json_fields.hpp) end a type mismatch with ", got <JSON type>".
_TYPE_MISMATCH = re.compile(r"got (null|object|array|string|boolean|number)$")


def invalid_input(field: str, message: str) -> InvalidInput:
    """The exception for the C++ InvalidInput(field, message) (called by the extension)."""
    cls = InvalidInputType if _TYPE_MISMATCH.search(message) else InvalidInput
    return cls(field, message)
