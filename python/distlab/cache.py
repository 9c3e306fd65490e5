"""The field store: the cache directory of prepared Kelvin fields that ``distlab serve``
(``--cache-dir``), ``distlab kelvin`` (``"cache"``), :meth:`distlab.kelvin.Field.prepare`
(``cache_dir=``) and Dask workers share, on one machine or a shared filesystem (NFS included).

- An entry is named by the SHA-256 of everything that determines it (surface, l_x, centre,
  options, format), written to a private temporary, flushed and linked in: nobody reads a
  half-written entry, and the first complete entry wins. Every read checks its MAC (the store's
  ``cache.key``) and its stored inputs against the request.
- A preparation holds a lease (``<entry>.lock``) renewed every ``lease / 4``: another process
  wanting the same field waits for it (progress stage ``"wait"``; Ctrl-C and ``progress``
  cancel the wait) and loads it, so one field is prepared once however many processes ask at
  the same time. A holder that died is taken over at once on its own machine, after the lease
  (60 s) from another.
- ``cache_budget=`` (bytes) on a preparation, or :func:`gc`, evicts the least recently used
  entries (a load counts as a use) down to the budget, sparing the ones used in the last
  ``keep_recent`` seconds.

The same as ``distlab cache ls | verify | gc --json``."""

from __future__ import annotations

import os
from typing import Optional, Union

from . import _core

__all__ = ["default_dir", "ls", "verify", "gc"]

PathLike = Union[str, os.PathLike]


def default_dir() -> str:
    """The store ``distlab serve`` uses by default: ``$XDG_CACHE_HOME/distlab`` or
    ``~/.cache/distlab``."""
    return _core.cache_default_dir()


def _dir(dir: Optional[PathLike]) -> str:
    return default_dir() if dir is None else os.fspath(dir)


def ls(dir: Optional[PathLike] = None) -> dict:
    """The store's entries (most recently used first: ``name``, ``bytes``, ``last_used`` in Unix
    seconds, ``current`` and ``format``, and for a current one what it was prepared from: ``lx``,
    ``far_radius``, ``feature_angle``, ``grading`` (None: chosen), ``center``,
    ``surface_vertices``, ``surface_faces``, ``n_verts``, ``n_tets``), ``bytes`` in all, the
    preparations in progress (``leases``: ``name``, ``host``, ``pid``, ``started``, ``renewed``,
    ``lease_seconds``, ``state`` "held", "dead" or "expired") and writers' ``temporaries``.
    ``distlab.InvalidInput`` (field ``dir``) if ``dir`` is not a directory."""
    return _core.cache_ls(_dir(dir))


def verify(dir: Optional[PathLike] = None, fix: bool = False) -> dict:
    """Reads every entry whole and checks its MAC, format and name: ``entries`` with their
    ``status`` ("ok", "truncated", "bad_mac", "no_key", "old_format", "wrong_name",
    "unreadable") and counts ``ok``, ``bad``, ``removed``. ``fix`` removes the bad entries."""
    return _core.cache_verify(_dir(dir), bool(fix))


def gc(dir: Optional[PathLike] = None, budget: Optional[int] = None, keep_recent: float = 60) -> dict:
    """Evicts the least recently used entries until they take at most ``budget`` bytes (None:
    none are evicted), sparing those used in the last ``keep_recent`` seconds, and removes what
    processes that died left behind (temporaries, their locks). Safe while others prepare and
    read. Returns ``evicted`` (names), ``removed`` (file names), ``bytes_before``,
    ``bytes_after``, ``kept_recent``."""
    return _core.cache_gc(_dir(dir), budget, float(keep_recent))
