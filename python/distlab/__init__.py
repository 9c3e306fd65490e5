"""distlab from Python: the GAP metric, the Kelvin semantics-aware distance and the CBF rollouts
in-process (numpy in, numpy out, through the same C++ code and request validation as the
``distlab`` CLI), and :class:`Client` for the HTTP/WebSocket service.

Modules: :mod:`distlab.gap`, :mod:`distlab.kelvin`, :mod:`distlab.cbf`, :mod:`distlab.client`.
"""

from . import cbf, gap, kelvin
from .errors import InvalidInput, InvalidInputType

__all__ = ["gap", "kelvin", "cbf", "Client", "InvalidInput", "InvalidInputType"]
__version__ = "0.1.0"


def __getattr__(name):
    # The client needs requests/websocket/msgpack; import them only when it is used.
    if name == "Client":
        from .client import Client

        return Client
    raise AttributeError(f"module 'distlab' has no attribute {name!r}")
