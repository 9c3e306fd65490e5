"""distlab from Python: the GAP metric, the Kelvin semantics-aware distance, the CBF rollouts and
robots as a library (every distance of a URDF robot with its joint-space Jacobian) in-process
(numpy in, numpy out, through the same C++ code and request validation as the ``distlab`` CLI),
and :class:`Client` for the HTTP/WebSocket service.

Modules: :mod:`distlab.gap`, :mod:`distlab.kelvin` (with :mod:`distlab.cache`, the store of
prepared fields that processes and machines share), :mod:`distlab.cbf`, :mod:`distlab.robot`,
:mod:`distlab.client` (with :mod:`distlab.scene`: your own geometry in the service's views, and
recordings of them), :mod:`distlab.batch` (batch calls on a Dask cluster).

Optional dependencies, imported only when used: requests, websocket-client and msgpack for
:class:`Client`; dask.distributed (Debian: python3-distributed) for the ``client=`` of
:func:`distlab.cbf.sweep`, :func:`distlab.gap.distance` and :func:`distlab.kelvin.prepare_many`.
"""

import os as _os

from . import _paths


def _resolve(relative: str) -> str:
    return _os.path.normpath(_os.path.join(_os.path.dirname(_os.path.abspath(__file__)), relative))


#: The built-in meshes and CBF scenarios (the source tree's assets/, or share/distlab/assets when
#: installed); the C++ core looks there unless $DISTLAB_ASSETS says otherwise.
assets_dir = _resolve(_paths.ASSETS)
#: The front end's static files (``distlab serve --web``), the shaders, the programs' directory.
web_dir = _resolve(_paths.WEB)
shaders_dir = _resolve(_paths.SHADERS)
bin_dir = _resolve(_paths.BIN)
_os.environ.setdefault("DISTLAB_ASSETS", assets_dir)


def executable(name: str = "distlab") -> str:
    """The path of the ``distlab`` CLI (``distlab serve`` is the service) beside this package."""
    return _os.path.join(bin_dir, name)


from . import batch, cache, cbf, gap, kelvin, robot  # noqa: E402  (after DISTLAB_ASSETS is set)
from .errors import FieldUndefined, InvalidInput, InvalidInputType  # noqa: E402

__all__ = ["gap", "kelvin", "cbf", "robot", "batch", "cache", "Client", "InvalidInput", "InvalidInputType", "FieldUndefined", "assets_dir", "web_dir",
           "shaders_dir", "bin_dir", "executable"]
__version__ = "0.1.0"


def __getattr__(name):
    # The client needs requests/websocket/msgpack; import them only when it is used.
    if name == "Client":
        from .client import Client

        return Client
    raise AttributeError(f"module 'distlab' has no attribute {name!r}")
