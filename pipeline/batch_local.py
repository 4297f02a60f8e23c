"""The local engine of ``pcnet batch``: worker processes that this module supervises itself.

Why not ``concurrent.futures.ProcessPoolExecutor``: when the OS kills one of its workers
(an out-of-memory kill) the whole pool breaks (``BrokenProcessPool``) and every queued row
is lost. Here each worker is a ``spawn``-ed child running one row at a time over its own
pipe; the supervisor watches every child's pipe and process sentinel, so a dead child
fails (or, with retries left, re-queues) only the row it was running, and a fresh child
takes its place.

``spawn`` rather than ``fork``: a fresh interpreter imports numpy after the thread-count
variables are in its environment, and inherits no threads or locks of the supervisor.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import wait

from .batch_worker import execute_row, set_opencv_threads, thread_env, threads_per_worker
from .interrupt import STOP_SIGNALS, came_from_interrupt, quiet_interrupt_hook, raise_interrupt

#: Seconds a worker gets to unwind after SIGTERM (remove its half-written folder) before SIGKILL.
TERMINATE_GRACE_S = 1.0
_POLL_S = 0.5


def _worker_main(conn, threads: int) -> None:
    """A worker's loop: receive a job, send back its result; ``None`` or a closed pipe ends it.

    SIGINT and SIGHUP are ignored (the supervisor decides what a Ctrl-C or a closed terminal
    stops); SIGTERM unwinds as ``KeyboardInterrupt`` like ``pcnet run``'s, so the row's staged
    output folder is removed before the process exits.
    """
    for signum in (signal.SIGINT, *(s for s in STOP_SIGNALS if s != signal.SIGTERM)):
        signal.signal(signum, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, raise_interrupt)
    sys.unraisablehook = quiet_interrupt_hook(sys.unraisablehook)
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_stop_with, args=(parent.sentinel,), daemon=True).start()
    try:
        set_opencv_threads(threads)
        import pcnet.pipeline.runner  # noqa: F401 - imported once per worker, not inside the first row's time
        while True:
            try:
                job = conn.recv()
            except EOFError:  # the supervisor is gone
                return
            if job is None:
                return
            conn.send(execute_row(job))
    except KeyboardInterrupt:
        return
    except Exception as err:  # a SIGTERM inside an import comes out as the module's ImportError
        if not came_from_interrupt(err):
            raise


def _stop_with(parent_sentinel) -> None:
    """Unwind this worker as SIGTERM does once the supervisor is gone (killed by SIGKILL, which
    it cannot pass on): a user trial's orphaned worker ran its row on and published it, racing
    the batch started again."""
    wait([parent_sentinel])
    os.kill(os.getpid(), signal.SIGTERM)


@dataclass
class _Worker:
    process: multiprocessing.Process
    conn: object
    job: dict | None = None


@dataclass
class LocalEngine:
    """Run jobs (see :func:`pcnet.pipeline.batch_worker.execute_row`) in ``workers`` child
    processes; a job whose worker died is retried up to ``retries`` more times.

    ``on_result`` is called with each row's final result as it arrives. :meth:`run` returns
    ``(results, interrupted)``: on ``KeyboardInterrupt`` (Ctrl-C, SIGTERM) no further row
    starts, the running children are terminated, and the unfinished rows are absent from
    ``results`` (the caller reports them as cancelled).
    """

    workers: int
    retries: int = 0
    on_result: Callable[[dict], None] = lambda result: None
    #: Told, in one line, when a worker died and its row starts again.
    on_retry: Callable[[int, str], None] = lambda row, line: None
    _pool: list[_Worker] = field(default_factory=list)
    _threads: int = 1
    #: row -> the last attempt's ``attempts``, ``host``, ``pid`` and ``threads``, as it started
    #: (what a row cancelled while running reports).
    started: dict[int, dict] = field(default_factory=dict)

    def run(self, jobs: list[dict]) -> tuple[list[dict], bool]:
        if not jobs:
            return [], False
        pending = deque(dict(job, attempt=1) for job in jobs)
        results: list[dict] = []
        ctx = multiprocessing.get_context("spawn")
        threads = self._threads = threads_per_worker(min(self.workers, len(jobs)))
        try:
            while pending or any(w.job is not None for w in self._pool):
                self._staff(ctx, threads, len(pending))
                self._dispatch(pending)
                self._collect(pending, results)
        except KeyboardInterrupt:
            self._stop_all(results)
            return results, True
        self._close_all()
        return results, False

    def _staff(self, ctx, threads: int, waiting: int) -> None:
        """Start children until every waiting row has one (at most ``workers`` in all)."""
        idle = sum(w.job is None for w in self._pool)
        while waiting > idle and len(self._pool) < self.workers:
            parent, child = ctx.Pipe()
            process = ctx.Process(target=_worker_main, args=(child, threads), daemon=True)
            with environment(thread_env(threads)):  # a spawned child copies it at start
                process.start()
            child.close()
            self._pool.append(_Worker(process, parent))
            idle += 1

    def _dispatch(self, pending: deque) -> None:
        for worker in self._pool:
            if worker.job is None and pending:
                worker.job = pending.popleft()
                self.started[worker.job["row"]] = {"attempts": worker.job["attempt"], "host": socket.gethostname(),
                                                   "pid": worker.process.pid, "threads": self._threads}
                try:
                    worker.conn.send(worker.job)
                except OSError:  # the child died before its first job: seen by _collect
                    pass

    def _collect(self, pending: deque, results: list[dict]) -> None:
        """Wait for a result or a death, then file it."""
        waitables = {}
        for worker in self._pool:
            waitables[worker.conn] = worker
            waitables[worker.process.sentinel] = worker
        for ready in wait(list(waitables), timeout=_POLL_S):
            worker = waitables[ready]
            if worker not in self._pool:  # both its pipe and sentinel were ready
                continue
            result = _receive(worker.conn)
            if result is not None:
                worker.job = None
                self._finish(result, results)
            elif not worker.process.is_alive() or ready is worker.conn:
                self._bury(worker, pending, results)

    def _bury(self, worker: _Worker, pending: deque, results: list[dict]) -> None:
        """A child died (killed by the OS or a user): its row is retried or failed."""
        worker.process.join(timeout=TERMINATE_GRACE_S)
        worker.conn.close()
        self._pool.remove(worker)
        job = worker.job
        if job is None:
            return
        if job["attempt"] <= self.retries:
            pending.appendleft(dict(job, attempt=job["attempt"] + 1))
            self.on_retry(job["row"], f"{death_line(worker.process.pid, worker.process.exitcode)}; starting it again "
                                      f"(attempt {job['attempt'] + 1} of {self.retries + 1})")
            return
        self._finish({"row": job["row"], "status": "failed", "frames": None, "valid": None, "mode": "", "seconds": None,
                      "error": death_line(worker.process.pid, worker.process.exitcode),
                      "host": socket.gethostname(), "pid": worker.process.pid, "attempts": job["attempt"],
                      "threads": self._threads}, results)

    def _finish(self, result: dict, results: list[dict]) -> None:
        results.append(result)
        self.on_result(result)

    def _stop_all(self, results: list[dict]) -> None:
        """File the results already sent, then SIGTERM every child (each removes its staged
        folder) and SIGKILL what is left after :data:`TERMINATE_GRACE_S`. A second Ctrl-C
        meanwhile is ignored: the stop is bounded."""
        with sigint_ignored():
            for worker in self._pool:
                result = _receive(worker.conn) if worker.job is not None else None
                if result is not None:
                    worker.job = None
                    self._finish(result, results)
            for worker in self._pool:
                with contextlib.suppress(OSError):
                    worker.process.terminate()
            deadline = time.monotonic() + TERMINATE_GRACE_S
            for worker in self._pool:
                worker.process.join(timeout=max(0.0, deadline - time.monotonic()))
                if worker.process.is_alive():
                    worker.process.kill()
                    worker.process.join(timeout=TERMINATE_GRACE_S)
                worker.conn.close()
            self._pool.clear()

    def _close_all(self) -> None:
        for worker in self._pool:
            with contextlib.suppress(OSError):
                worker.conn.send(None)
        for worker in self._pool:
            worker.process.join(timeout=5)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            worker.conn.close()
        self._pool.clear()


def _receive(conn) -> dict | None:
    """The result waiting on ``conn``, or ``None`` when there is none (or the child died)."""
    try:
        return conn.recv() if conn.poll() else None
    except (EOFError, OSError):
        return None


def death_line(pid: int | None, exitcode: int | None) -> str:
    """A dead worker's one-line error, naming the signal (SIGKILL is what an out-of-memory
    kill looks like)."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        hint = " (as an out-of-memory kill does)" if name == "SIGKILL" else ""
        return f"worker process {pid} was killed by {name}{hint} while running this row"
    return f"worker process {pid} exited with status {exitcode} while running this row"


@contextlib.contextmanager
def sigint_ignored():
    """Ignore SIGINT inside the block (only the main thread may change signal handlers;
    elsewhere the block runs unchanged)."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def environment(values: dict[str, str]):
    """Set environment variables for the duration of the block, then restore them."""
    saved = {name: os.environ.get(name) for name in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
