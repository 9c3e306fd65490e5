"""Batch calls on a Dask cluster: the ``client=`` of :func:`distlab.cbf.sweep`,
:func:`distlab.gap.distance` and :func:`distlab.kelvin.prepare_many`.

dask.distributed (Debian's ``python3-distributed``) is an optional dependency: it is imported only
when a ``client=`` (a ``dask.distributed.Client``) is given. Each call becomes tasks of the
package's own in-process calls (one per CBF run, per chunk of GAP pairs, per Kelvin mesh), so every
task computes what the local call computes; their results come back as numpy arrays (pickled, not
JSON text) and are put together in the input's order. Inputs travel inside the tasks, so a worker
that dies loses nothing Dask cannot recompute: its tasks run again elsewhere (up to Dask's
``distributed.scheduler.allowed-failures``).

Progress is the local call's (``progress(stage, fraction)``, or ``progress(done, total)`` for GAP
pairs), aggregated over the tasks: finished tasks, plus each running task's own progress, sent
as worker events (``Worker.log_event``) at most every 0.2 s. Cancelling (Ctrl-C in a waiting call,
an exception raised by ``progress``, or :meth:`Batch.cancel`) cancels the futures and stops the
running tasks through the package's one mechanism: their progress callbacks raise, which sets the
C++ cancellation token.
"""

from __future__ import annotations

import concurrent.futures
import threading
import time
import uuid
import weakref
from typing import Any, Callable, List, Optional, Sequence, Tuple

__all__ = ["Batch"]

_TOPIC = "distlab-progress"  # worker events (batch id, task index, progress value)
_EVERY = 0.2  # seconds between one task's progress events
_CALL_EVERY = 0.1  # seconds between progress calls on the client (the last one always comes)

_batches: "weakref.WeakValueDictionary[str, Batch]" = weakref.WeakValueDictionary()  # on the client
_subscribed: "weakref.WeakSet[Any]" = weakref.WeakSet()  # clients with _on_event on _TOPIC
_cancelled: set = set()  # in a worker process: ids of the batches cancelled (Batch.cancel)


class _Stopped(Exception):
    """Raised on a worker by a task's progress callback once its batch is cancelled."""


def _cancel_here(batch: str) -> None:
    """Runs on every worker (client.run): the batch's running tasks stop at their next progress."""
    _cancelled.add(batch)


class _Reporter:
    """A task's progress callback on its worker: stops the task once its batch is cancelled, and
    sends its progress value to the client at most every _EVERY seconds."""

    def __init__(self, batch: str, index: int):
        self.batch, self.index = batch, index
        self._last = -float("inf")

    def __call__(self, value: float) -> None:
        if self.batch in _cancelled:
            raise _Stopped(f"batch {self.batch} was cancelled")
        now = time.monotonic()
        if now - self._last < _EVERY:
            return
        self._last = now
        from distributed import get_worker

        try:
            worker = get_worker()
        except ValueError:  # not on a worker: nobody to tell
            return
        worker.log_event(_TOPIC, (self.batch, self.index, float(value)))


def _run(batch: str, index: int, work: Callable[..., Any], args: tuple) -> Any:
    """One task: work(*args, report), report taking the task's progress value. A task its batch
    stopped returns None: the batch is cancelled and reads nothing, and an exception would be
    logged by the worker as a failed task ("Compute Failed ... _Stopped") on every cancel."""
    try:
        return work(*args, _Reporter(batch, index))
    except _Stopped:
        return None


def _on_event(event) -> None:
    """The client's handler of _TOPIC (on the client's event loop thread)."""
    _, (batch, index, value) = event
    b = _batches.get(batch)
    if b is not None:
        b._task_progress(index, value)


def require_client(client: Any):
    """The dask.distributed module, once ``client`` is checked to be one of its (synchronous)
    clients: the one place that imports it."""
    try:
        import distributed
    except ImportError as e:  # pragma: no cover  (Debian's python3-distributed is missing)
        raise ImportError("client= needs dask.distributed (Debian: python3-distributed)") from e
    if not isinstance(client, distributed.Client):
        raise TypeError(f"client: expected a dask.distributed.Client, got {type(client).__name__}")
    if client.asynchronous:
        raise TypeError("client: an asynchronous dask.distributed.Client is not supported")
    return distributed


def count_report(noun: str) -> Callable[[List[bool], List[float]], Tuple[str, float]]:
    """Progress of N tasks reporting fractions: ("K of N <noun>", mean fraction)."""

    def report(finished: List[bool], partial: List[float]) -> Tuple[str, float]:
        n = len(finished)
        k = sum(finished)
        f = sum(1.0 if done else min(1.0, p) for done, p in zip(finished, partial))
        return f"{k} of {n} {noun}", (f / n if n else 1.0)

    return report


def sum_report(sizes: Sequence[int]) -> Callable[[List[bool], List[float]], Tuple[int, int]]:
    """Progress of tasks of ``sizes[i]`` items reporting items done: (done, total)."""

    def report(finished: List[bool], partial: List[float]) -> Tuple[int, int]:
        done = sum(s if f else min(s, int(p)) for s, f, p in zip(sizes, finished, partial))
        return done, int(sum(sizes))

    return report


class Batch:
    """The tasks of one batch call on a Dask cluster, as the call returns them with
    ``wait=False``: :meth:`progress`, :meth:`wait`, :meth:`cancel`, :meth:`result` (the call's
    result). ``id`` names the batch (its task keys are ``<id>-<index>``)."""

    def __init__(self, client: Any, name: str, work: Callable[..., Any], tasks: Sequence[tuple],
                 combine: Callable[[List[Any]], Any], report: Callable[[List[bool], List[float]], tuple],
                 translate: Optional[Callable[[int, BaseException], BaseException]] = None):
        require_client(client)
        self.client = client
        self.id = f"distlab-{name}-{uuid.uuid4().hex[:12]}"
        self._combine, self._report, self._translate = combine, report, translate
        n = len(tasks)
        self._lock = threading.Lock()  # _partial, _finished
        self._changed = threading.Event()  # a task finished or reported
        self._partial = [0.0] * n
        self._finished = [False] * n
        self._results: List[Any] = [None] * n
        self._cancelled = False
        self._value: Any = None
        self._have_value = False
        _batches[self.id] = self
        if client not in _subscribed:
            client.subscribe_topic(_TOPIC, _on_event)
            _subscribed.add(client)
        # One graph for all tasks; the inputs inside the tasks (recomputable wherever they run).
        self._futures: List[Any] = client.map(_run, [self.id] * n, range(n), [work] * n, list(tasks),
                                              key=[f"{self.id}-{i}" for i in range(n)], pure=False)
        for f in self._futures:
            f.add_done_callback(lambda _: self._changed.set())

    def __len__(self) -> int:
        return len(self._finished)

    def __repr__(self) -> str:
        state = "cancelled" if self._cancelled else "done" if self.done() else "running"
        return f"<Batch {self.id}: {len(self)} tasks, {state}>"

    def _task_progress(self, index: int, value: float) -> None:
        with self._lock:
            if 0 <= index < len(self._partial) and not self._finished[index]:
                # A task run again after its worker died starts over: progress never goes back.
                self._partial[index] = max(self._partial[index], value)
        self._changed.set()

    def done(self) -> bool:
        """Whether every task has finished (its result is here)."""
        with self._lock:
            return all(self._finished)

    def cancelled(self) -> bool:
        return self._cancelled

    def progress(self) -> tuple:
        """The call's progress arguments now: (stage, fraction), or (done, total) for GAP."""
        with self._lock:
            return self._report(list(self._finished), list(self._partial))

    def cancel(self) -> None:
        """Cancels the tasks: those waiting never start, those running stop at their next progress
        check; :meth:`result` then raises ``concurrent.futures.CancelledError``."""
        if self._cancelled or self.done():
            return
        self._cancelled = True
        live = [f for f in self._futures if f is not None]
        try:  # running tasks first, so that none starts between the two
            self.client.run(_cancel_here, self.id, on_error="ignore")
        except Exception:  # noqa: BLE001  (best effort: the cancelled futures deliver nothing anyway)
            pass
        self.client.cancel(live)
        self._changed.set()

    def _collect(self) -> None:
        """Takes the results of the tasks finished since the last call (their futures are released);
        a failed task cancels the others and raises its error."""
        if self._cancelled:
            raise concurrent.futures.CancelledError(f"{self.id} was cancelled")
        with self._lock:
            pending = [i for i, done in enumerate(self._finished) if not done]
        states = {i: self._futures[i].status for i in pending}
        for i in pending:
            if states[i] == "error":
                self._fail(i)
            if states[i] == "cancelled":
                self.cancel()
                raise concurrent.futures.CancelledError(f"{self.id}: task {i} was cancelled outside the batch")
        ready = [i for i in pending if states[i] == "finished"]
        if not ready:
            return
        values = self.client.gather([self._futures[i] for i in ready])
        with self._lock:
            for i, v in zip(ready, values):
                self._results[i] = v
                self._finished[i] = True
                self._futures[i] = None

    def _fail(self, i: int) -> None:
        future = self._futures[i]
        error, tb = future.exception(), future.traceback()
        self.cancel()
        translated = self._translate(i, error) if self._translate is not None else error
        if translated is not error:
            raise translated from error
        raise error.with_traceback(tb)

    def wait(self, progress: Optional[Callable[..., Any]] = None, timeout: Optional[float] = None) -> Any:
        """Waits for every task and returns the call's result. ``progress(...)`` is called on this
        thread as the tasks advance (at most every 0.1 s, and once with the final values); Ctrl-C
        (KeyboardInterrupt), or an exception raised by ``progress``, cancels the batch and
        propagates, as does a task's error (after cancelling the others). A ``timeout`` (seconds)
        raises TimeoutError and leaves the batch running."""
        end = None if timeout is None else time.monotonic() + timeout
        last_args: Any = None
        last_call = -float("inf")
        try:
            while True:
                self._changed.clear()
                self._collect()
                finished = self.done()
                if progress is not None:
                    args = self.progress()
                    now = time.monotonic()
                    if args != last_args and (finished or now - last_call >= _CALL_EVERY):
                        last_args, last_call = args, now
                        try:
                            progress(*args)
                        except BaseException:
                            self.cancel()
                            raise
                if finished:
                    break
                wait = _CALL_EVERY
                if end is not None:
                    wait = min(wait, end - time.monotonic())
                    if wait <= 0:
                        raise TimeoutError(f"{self.id}: {self.progress()} after {timeout} s")
                self._changed.wait(wait)
        except KeyboardInterrupt:
            self.cancel()
            raise
        return self.result()

    def result(self) -> Any:
        """The call's result (waits for it without progress)."""
        if not self._have_value:
            if not self.done():
                return self.wait()
            self._value = self._combine(self._results)
            self._have_value = True
            self._results = []
        return self._value
