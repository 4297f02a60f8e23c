"""The Ray engine of ``pcnet batch``: one Ray task per manifest row.

Ray re-runs a task whose worker process died (``max_retries``; an exception raised by the
row itself is its result and is not retried, a bad input fails the same way every time).
Results are taken with ``ray.wait`` as they finish. Without an address a local Ray
instance with ``workers`` CPUs is started (and stopped afterwards); with one, the driver
joins that cluster, which every node must reach the inputs and outputs on (a shared file
system, docs/cluster.md).
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

from pcnet.stages.core.errors import InputError, import_extra

from .batch_local import environment, sigint_ignored
from .batch_worker import TEST_HOOK, cpu_cores, execute_row, set_opencv_threads, thread_env, threads_per_worker

RAY_MISSING = 'pcnet batch --engine ray needs Ray: pip install "pcnet[ray]"'
_POLL_S = 0.5
#: Seconds given to force-cancelled tasks to end before the driver reports and returns.
CANCEL_GRACE_S = 1.0


def import_ray():
    """The ``ray`` module.

    Raises:
        InputError: Ray is not installed (the ``ray`` extra), one line saying how to get it.
    """
    return import_extra("ray", RAY_MISSING)


class _Attempts:
    """A Ray actor counting the attempts at each row: Ray does not tell a retried task
    that it is a retry, and a row whose last worker died has no result to say so."""

    def __init__(self):
        self.seen: dict[int, dict] = {}

    def start(self, row: int, host: str, pid: int) -> int:
        entry = self.seen.setdefault(row, {"attempts": 0})
        entry.update(attempts=entry["attempts"] + 1, host=host, pid=pid)
        return entry["attempts"]

    def last(self, row: int) -> dict:
        return self.seen.get(row, {"attempts": 0})

    def retried(self) -> dict[int, dict]:
        """The rows started more than once, with their last attempt."""
        return {row: dict(entry) for row, entry in self.seen.items() if entry["attempts"] > 1}


#: Seconds a cluster address gets to accept a connection before the batch gives up on it.
CONNECT_TIMEOUT_S = 5.0


def check_reachable(address: str) -> None:
    """Refuse a ``HOST:PORT`` cluster address that accepts no connection within
    :data:`CONNECT_TIMEOUT_S` (``ray.init`` would retry it for minutes, printing only Ray's
    own log lines). ``auto``, ``ray://...`` (Ray Client) and other forms Ray resolves itself
    are left to Ray.

    Raises:
        InputError: naming ``--address``, what was expected and what was found.
    """
    host, sep, port = address.rpartition(":")
    if "://" in address or not sep or not port.isdigit() or not host:  # ray://... (Ray Client) and the like
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except TimeoutError:
        raise InputError(f"--address {address}: expected a running Ray cluster's head (`ray start --head` prints its "
                         f"address), got no answer within {CONNECT_TIMEOUT_S:g} s") from None
    except OSError as err:
        raise InputError(f"--address {address}: expected a running Ray cluster's head (`ray start --head` prints its "
                         f"address), got no connection ({err.strerror or err})") from None


def ray_row(job: dict, attempts, threads: int) -> dict:
    """The Ray task body: count the attempt, then :func:`execute_row`.

    The count is read only after the row ran: a task blocked in ``ray.get`` hands its CPU
    back to Ray, which would start another row beside it and oversubscribe the node.
    """
    import ray

    counted = attempts.start.remote(job["row"], socket.gethostname(), os.getpid())
    set_opencv_threads(threads)
    result = execute_row(job)
    result["attempts"] = ray.get(counted)
    return result


@dataclass
class RayEngine:
    """Run jobs as Ray tasks. ``address`` ``None`` starts a local instance with ``workers``
    CPUs; otherwise ``workers`` (when given) caps the rows in flight on the cluster.

    :meth:`run` returns ``(results, interrupted)`` like
    :class:`pcnet.pipeline.batch_local.LocalEngine`: on ``KeyboardInterrupt`` every
    unfinished task is force-cancelled (its worker process killed) and left out of
    ``results``.
    """

    workers: int | None
    retries: int = 0
    address: str | None = None
    on_result: Callable[[dict], None] = lambda result: None
    #: Told, in one line, when a row starts again after its worker died (as the local engine's).
    on_retry: Callable[[int, str], None] = lambda row, line: None
    start_seconds: float = 0.0

    def run(self, jobs: list[dict]) -> tuple[list[dict], bool]:
        if not jobs:
            return [], False
        ray = import_ray()
        owned = not ray.is_initialized()  # a program (or test) that already called ray.init keeps its Ray
        local = owned and not self.address
        threads = threads_per_worker(self.workers or cpu_cores()) if local else 1
        env = thread_env(threads)
        if os.environ.get(TEST_HOOK):
            env[TEST_HOOK] = os.environ[TEST_HOOK]
        started = time.perf_counter()
        if owned:
            self._init(ray, env if local else {})
        self.start_seconds = time.perf_counter() - started
        try:
            # The local instance started here passed the variables to every worker already;
            # elsewhere a runtime environment carries them (it costs dedicated workers).
            return self._run(ray, jobs, threads, None if local else {"env_vars": env})
        finally:
            if owned:
                ray.shutdown()  # stops the local instance; on a cluster only disconnects

    def _init(self, ray, env: dict[str, str]) -> None:
        """Join the cluster at ``address``, or start a local instance with ``workers`` CPUs
        whose worker processes inherit ``env`` (Ray's own processes copy it at start)."""
        options = {"log_to_driver": False, "logging_level": logging.ERROR}
        if self.address:
            try:
                ray.init(address=self.address, **options)
            except ConnectionError as err:
                raise InputError(f"--address {self.address}: expected a Ray cluster this machine may join, got "
                                 f"'{err}'; a cluster with token authentication (Ray's default from 2.61) needs "
                                 f"RAY_AUTH_MODE=token and its token here too (docs/cluster.md, Ray)") from None
            return
        # "local": a new instance even where a cluster runs on this machine (`ray start
        # --head`), which ray.init would otherwise join, refusing num_cpus.
        with environment(env):
            ray.init(address="local", num_cpus=self.workers or cpu_cores(), include_dashboard=False, **options)

    def _run(self, ray, jobs: list[dict], threads: int, runtime_env: dict | None) -> tuple[list[dict], bool]:
        # Each task reserves one CPU, so a node runs one task per CPU (one thread each on a
        # cluster; cores // workers on the local instance started with --workers CPUs).
        attempts = ray.remote(num_cpus=0)(_Attempts).remote()
        # Until the counter's process is up, a task's count waits inside its own worker and
        # dies with it; a counter that is alive before any task starts receives each count
        # within milliseconds of the attempt's start.
        ray.get(attempts.last.remote(-1))
        task = ray.remote(num_cpus=1, max_retries=self.retries, retry_exceptions=False)(ray_row)
        if runtime_env:
            task = task.options(runtime_env=runtime_env)
        cap = self.workers if self.address and self.workers else len(jobs)
        queue, in_flight, results, announced = list(jobs), {}, [], {}
        try:
            while queue or in_flight:
                while queue and len(in_flight) < cap:
                    job = queue.pop(0)
                    in_flight[task.remote(job, attempts, threads)] = job
                done, _ = ray.wait(list(in_flight), num_returns=1, timeout=_POLL_S)
                if self.retries:
                    self._announce_retries(ray, attempts, announced)
                for ref in done:
                    result = self._result(ray, ref, in_flight.pop(ref), attempts)
                    results.append(result)
                    self.on_result(result)
        except KeyboardInterrupt:
            with sigint_ignored():  # a second Ctrl-C while stopping is ignored: the stop is bounded
                self._drain(ray, in_flight, attempts, results)
                _cancel_all(ray, list(in_flight))
            return results, True
        return results, False

    def _announce_retries(self, ray, attempts, announced: dict[int, int]) -> None:
        """Say each new attempt at a row whose worker died (Ray re-runs the task itself)."""
        for row, last in ray.get(attempts.retried.remote()).items():
            if announced.get(row, 1) < last["attempts"]:
                announced[row] = last["attempts"]
                self.on_retry(row, f"its Ray worker died; starting it again on {last.get('host', '?')} (pid "
                                   f"{last.get('pid')}, attempt {last['attempts']} of {self.retries + 1})")

    def _drain(self, ray, in_flight: dict, attempts, results: list[dict]) -> None:
        """File the results of tasks that finished before the interrupt was seen."""
        try:
            done, _ = ray.wait(list(in_flight), num_returns=len(in_flight), timeout=0)
            for ref in done:
                result = self._result(ray, ref, in_flight.pop(ref), attempts)
                results.append(result)
                self.on_result(result)
        except Exception:  # noqa: BLE001 - a local instance stopped by the same Ctrl-C: nothing to file
            pass

    def _result(self, ray, ref, job: dict, attempts) -> dict:
        """The task's result, or a failed row when its last worker died (retries spent)."""
        try:
            return ray.get(ref)
        except ray.exceptions.RayError as err:
            last = ray.get(attempts.last.remote(job["row"]))
            return {"row": job["row"], "status": "failed", "frames": None, "valid": None, "mode": "", "seconds": None,
                    "error": _death_line(ray, err, last), "host": last.get("host", ""), "pid": last.get("pid"),
                    "attempts": last["attempts"]}


def _death_line(ray, err, last: dict) -> str:
    """A failed task's one-line error: how its worker (or node) died, when Ray says so."""
    ended = f"while running the row, after {last['attempts']} attempt(s)"
    if isinstance(err, ray.exceptions.OutOfMemoryError):
        return f"its Ray worker process (pid {last.get('pid')}) was killed by Ray's memory monitor (the node ran low " \
               f"on memory) {ended}"
    if isinstance(err, ray.exceptions.NodeDiedError):
        return f"the Ray node running it ({last.get('host') or '?'}) died {ended}"
    if isinstance(err, ray.exceptions.WorkerCrashedError):
        return f"its Ray worker process (pid {last.get('pid')}) died (killed, as an out-of-memory kill does) {ended}"
    return f"Ray: {_first_line(err)}"


def _cancel_all(ray, refs: list) -> None:
    """Force-cancel (kill the workers of) every unfinished task, waiting a moment so that
    the caller can clean their staged folders once their processes are gone."""
    for ref in refs:
        try:
            ray.cancel(ref, force=True)
        except Exception:  # noqa: BLE001 - a task that finished meanwhile cannot be cancelled
            pass
    if refs:
        try:
            ray.wait(refs, num_returns=len(refs), timeout=CANCEL_GRACE_S)
        except Exception:  # noqa: BLE001 - a local instance stopped by the same Ctrl-C
            pass


def _first_line(err: BaseException) -> str:
    lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
    return lines[0] if lines else type(err).__name__
