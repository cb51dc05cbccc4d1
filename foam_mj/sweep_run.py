"""Running a sweep: the output folder (a Parquet dataset) and the engines (a local process pool or Ray); its progress
display is foam_mj.progress.SweepProgress.

Output folder ``DIR``::

    DIR/sweep.json          what the rows are (base scenario, swept keys and their kinds, columns)
    DIR/rows/part-*.parquet the rows, in batches; read DIR/rows as one dataset (pyarrow, DuckDB, pandas)
    DIR/.lock               held while a sweep writes (a second sweep on DIR is refused)

Nothing is lost: rows are kept in memory only until the next batch (``batch`` rows or ``flush_seconds``,
whichever first) and each batch is written to a hidden temporary file in ``DIR/rows`` and renamed
into place (atomic on POSIX), so a reader never sees a partial file, and a kill loses at most the rows
of the current batch. Ctrl-C writes the rows completed so far before exiting (130). A re-run reads the
keys already in ``DIR/rows`` and runs only the tasks with a missing row, so it ends with exactly the
rows of an uninterrupted run, each once. The folder belongs to one sweep: a sweep file with another
base scenario, replay mode or set of swept keys is refused (exit 2); more values, seeds or smoothers are fine
(a task re-run for a new path writes only the rows not yet there).

Engines run the same :func:`foam_mj.sweep.run_task` on picklable tasks, so they give the same rows:

* ``local`` (default): a ``concurrent.futures`` process pool (``spawn``), one worker per core unless
  told, each keeping its compiled MuJoCo models between tasks. A worker that dies (killed, out of
  memory) breaks the pool: the rows already received are kept, the unfinished tasks are sent to a new
  pool (up to :data:`MAX_POOL_RESTARTS` times).
* ``ray``: the same tasks as Ray tasks (``pip install foam-mj[cluster]``); with no address a local Ray
  instance is started with ``workers`` CPUs, with an address (``auto``, ``ray://host:10001``, ...) a
  running cluster is joined. Ray re-runs a task whose worker died (``max_retries``). On a cluster every
  node needs foam-mj installed, and a scenario given by path must exist at the same path on every node
  (built-in scenarios are found by name).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

from foam_mj.errors import FoamError
from foam_mj.progress import SweepProgress
from foam_mj.sweep import Sweep, SweepError, Task, WorkersDied, run_task
from foam_mj.sweep_store import MANIFEST, ROWS, RowStore, _pyarrow, read_manifest, read_rows  # noqa: F401 (re-exported: the CLI, report and tests import them from here)

#: How many times a broken local pool is replaced before the sweep gives up.
MAX_POOL_RESTARTS = 3

# ------------------------------------------------------------------------------------------- engines

#: (task, rows) for a finished task, or (None, None) when nothing finished for a while (a tick).
Event = tuple[Task | None, list[dict] | None]

#: The event an engine yields when Ctrl-C or SIGTERM reaches it while it waits: the sweep writes the rows it has
#: received, then closes the engine, so that the engine's teardown (Ray's shutdown) comes after the rows are safe.
INTERRUPTED: Event = (None, [])


def _worker_init() -> None:
    """A pool worker ignores Ctrl-C (the sweep's to handle: it writes its rows and stops us), ends quietly on SIGTERM
    (how the sweep stops its pool, also when it is done: a worker that re-ran the ``foam-mj`` script as its main module
    holds foam_mj.__main__'s handler, which would print "foam-mj: interrupted"), and ends when the sweep's process dies
    (``kill -9``, out of memory): it would otherwise wait on the task queue forever."""
    import multiprocessing as mp
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C held back while this worker started (_ctrl_c_held) is dropped
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = mp.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent.sentinel,), daemon=True, name="foam-mj-parent-watch").start()


@contextlib.contextmanager
def _ctrl_c_held() -> Iterator[None]:
    """Block SIGINT in this thread while the pool may start workers (ProcessPoolExecutor spawns them in ``submit``).
    A spawned worker inherits the blocked signal across exec and keeps it so until :func:`_worker_init` ignores it:
    before that it spends 0.5-5 s importing foam_mj, numpy and MuJoCo under Python's default handler, and a Ctrl-C
    (sent to the whole process group) printed the worker's KeyboardInterrupt traceback above the sweep's own line.
    The sweep's own Ctrl-C is only delayed: it is delivered when the mask is restored."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _exit_with(sentinel: int) -> None:
    """Wait until ``sentinel`` (the parent's end of the spawn pipe) closes, then end this process at once."""
    from multiprocessing.connection import wait

    wait([sentinel])
    os._exit(1)


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def local_engine(tasks: Iterator[Task], workers: int, *, poll: float = 0.5) -> Iterator[Event]:
    """Run tasks in a process pool of ``workers`` (spawned processes); yields as they finish."""
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = mp.get_context("spawn")
    limit = 2 * workers
    retry: deque[Task] = deque()
    restarts = 0
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    inflight: dict = {}
    exhausted = False
    try:
        while True:
            # A worker can die between two waits: the pool is then broken, and submit raises. The task goes back
            # to the front of the queue, and the futures in flight end with BrokenProcessPool below.
            refused = False
            task: Task | None
            while len(inflight) < limit and (retry or not exhausted):
                if retry:
                    task = retry.popleft()
                else:
                    task = next(tasks, None)
                    if task is None:
                        exhausted = True
                        break
                try:
                    with _ctrl_c_held():
                        future = pool.submit(run_task, task)
                    inflight[future] = task
                except BrokenProcessPool:
                    retry.appendleft(task)
                    refused = True
                    break
            if not inflight and not refused:
                return
            broken = refused and not inflight
            if inflight:
                finished, _ = wait(list(inflight), timeout=poll, return_when=FIRST_COMPLETED)
                if not finished:
                    yield None, None
                    continue
                for fut in finished:
                    task = inflight.pop(fut)
                    try:
                        rows = fut.result()
                    except BrokenProcessPool:
                        broken = True
                        retry.append(task)
                        continue
                    yield task, rows
            if broken:
                retry.extend(inflight.values())
                inflight.clear()
                restarts += 1
                if restarts > MAX_POOL_RESTARTS:
                    raise WorkersDied(f"local workers died {restarts} times; the rows received so far are kept, re-run to continue")
                print(f"sweep: a worker died; restarting the pool ({len(retry)} unfinished tasks resent)", file=sys.stderr)
                _terminate(pool)
                pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    finally:
        _terminate(pool)


def _terminate(pool) -> None:
    """Stop a pool now: cancel what is queued and end its worker processes (ours, by their ids)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)


def check_ray_address(address: str) -> None:
    """A cluster address (``host:port`` or ``ray://host:port``; ``auto`` is Ray's to find) must accept a connection
    within a few seconds: ray.init waits minutes on an address where nothing listens, logging warnings."""
    import socket

    if address == "auto":
        return
    where = address.removeprefix("ray://")
    host, sep, port = where.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise FoamError(f"--ray {address}: expected auto, HOST:PORT or ray://HOST:PORT")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=5) as conn:
            reply = _http2_reply(conn)
    except OSError as exc:
        raise FoamError(f"--ray {address}: no Ray cluster answers there ({exc.strerror or type(exc).__name__}); "
                        "start one (ray start --head) or leave the address out for a local instance") from None
    if reply is not None:
        raise FoamError(f"--ray {address}: something answers there, but not a Ray cluster (it does not speak gRPC: {reply}); "
                        "give the head node's GCS address (ray start --head prints it) or ray://HOST:10001")


#: The client's opening of an HTTP/2 connection (RFC 9113 section 3.4): the preface, then an empty SETTINGS frame.
_HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])


def _http2_reply(conn) -> str | None:
    """None if the server on ``conn`` answers an HTTP/2 preface with a SETTINGS frame, as every gRPC server does
    (Ray's GCS and its client server speak gRPC); else what it did instead. ray.init on an address where a web
    server or anything else listens retried for minutes, printing 'Failed to connect to GCS' every few seconds."""
    import socket

    try:
        conn.sendall(_HTTP2_PREFACE)
        head = b""
        while len(head) < 9:
            chunk = conn.recv(9 - len(head))
            if not chunk:
                break
            head += chunk
    except socket.timeout:
        return "no reply within 5 s"
    except OSError as exc:
        return f"the connection failed: {exc.strerror or type(exc).__name__}"
    if len(head) == 9 and head[3] == 4:  # frame type 4: SETTINGS
        return None
    if not head:
        return "it closed the connection"
    text = head.decode("ascii", "replace")
    return f"it replied {text!r}" if text.isprintable() else f"it replied {head.hex()}"


def ray_engine(tasks: Iterator[Task], workers: int, address: str | None, *, poll: float = 0.5) -> Iterator[Event]:
    """Run tasks as Ray tasks: a local Ray instance (``address`` None) with ``workers`` CPUs, or a cluster."""
    try:
        import ray
    except ImportError:
        raise SweepError("--ray needs Ray: pip install 'foam-mj[cluster]'") from None
    import logging
    import threading

    kwargs: dict[str, Any] = dict(include_dashboard=False, logging_level=logging.ERROR, log_to_driver=False, configure_logging=True)
    main_thread = threading.current_thread() is threading.main_thread()
    sigterm = signal.getsignal(signal.SIGTERM) if main_thread else None
    if address:
        try:
            ray.init(address=address, **kwargs)
        except ConnectionError as exc:  # something answers there, but no Ray cluster
            raise SweepError(f"--ray {address}: {' '.join(str(exc).split())[:200]}") from None
    else:
        # A private local instance; workers inherit this environment (PYTHONPATH included).
        ray.init(num_cpus=workers, **kwargs)
    if sigterm is not None:
        # ray.init replaces the SIGTERM handler with sys.exit(15), which no `except KeyboardInterrupt` sees: a `kill`
        # would end the sweep with exit 1 or 143, its received rows unwritten. Ours comes back (the CLI's: Ctrl-C).
        signal.signal(signal.SIGTERM, sigterm)
    try:
        remote = ray.remote(num_cpus=1, max_retries=3)(run_task)
        limit = 2 * max(workers, int(ray.cluster_resources().get("CPU", workers)))
        inflight: dict = {}
        exhausted = False
        while True:
            while len(inflight) < limit and not exhausted:
                task = next(tasks, None)
                if task is None:
                    exhausted = True
                    break
                inflight[remote.remote(task)] = task
            if not inflight:
                return
            ready, _ = ray.wait(list(inflight), num_returns=1, timeout=poll)
            if not ready:
                yield None, None
                continue
            for ref in ready:
                task = inflight.pop(ref)
                yield task, ray.get(ref)
    except KeyboardInterrupt:
        # Raised here (in ray.wait, most often), it would run the teardown below before the sweep had written the
        # rows received. The sweep writes them, then closes this generator: GeneratorExit here, then the teardown.
        yield INTERRUPTED
        raise
    finally:
        # No ray.cancel of the tasks in flight: Ray 2.60 aborts the driver (task_manager.cc "Check failed: it !=
        # submissible_tasks_.end()", exit 1) when a cancelled task's reply arrives, 1 kill in 5, force or not.
        # ray.shutdown ends the job, and with it the job's workers and their tasks.
        ray.shutdown()


# ------------------------------------------------------------------------------------------ the sweep


@dataclass(frozen=True)
class SweepSummary:
    """What a run of a sweep did."""

    tasks: int  # tasks in the sweep
    skipped: int  # already done before this run
    run: int  # run now
    failed: int  # of those, tasks with a row not reached (the plan did not reach, or a path has no timing)
    rows_written: int
    files_written: int
    elapsed: float
    engine: str
    workers: int
    interrupted: bool = False

    @property
    def rate(self) -> float:
        return self.run / self.elapsed if self.elapsed > 0 else float("nan")


def run_sweep(
    sweep: Sweep,
    out: str | Path,
    *,
    engine: str = "local",
    workers: int | None = None,
    ray_address: str | None = None,
    batch: int = 200,
    flush_seconds: float = 10.0,
    progress: bool | None = None,
    interval: float = 5.0,
    limit: int | None = None,
    on_rows: Callable[[list[dict]], None] | None = None,
) -> SweepSummary:
    """Run every task of ``sweep`` whose rows are not yet in ``out`` and write the rows (module docstring).

    ``progress``: None shows it on stderr (rich on a terminal, plain lines otherwise), False hides it.
    ``limit`` stops after that many tasks of this run (to try a sweep on a few plans).
    KeyboardInterrupt is re-raised after the completed rows are written.
    """
    if engine not in ("local", "ray"):
        raise SweepError(f"unknown engine {engine!r}; choose local or ray")
    workers = default_workers() if workers is None else int(workers)
    if workers < 1:
        raise SweepError(f"--workers must be >= 1, got {workers}")
    if ray_address is None and workers > default_workers():
        # More processes than cores on this machine only share the cores (each plan is one thread) and add their
        # memory; a number written for a bigger machine still runs here.
        if progress is not False:
            print(f"sweep: --workers {workers} capped at {default_workers()}, the cores this process may use", file=sys.stderr)
        workers = default_workers()
    store = RowStore(Path(out), sweep, batch=batch, flush_seconds=flush_seconds, notes=progress is not False)
    store.open(sweep)
    t0 = time.monotonic()
    ran = failed = skipped = skipped_failed = 0
    interrupted = False
    bar = None
    try:
        done, not_reached = store.done_keys()
        total = sweep.n_tasks

        def todo() -> Iterator[Task]:
            nonlocal skipped, skipped_failed
            n = 0
            for task in sweep.tasks():
                if done and done.issuperset(task.keys):  # (no keys to hash on a first run)
                    skipped += 1
                    skipped_failed += not not_reached.isdisjoint(task.keys)
                    continue
                if limit is not None and n >= limit:
                    return
                n += 1
                yield task

        if total <= 200_000:  # the tasks to run, listed up front
            pending = list(todo())
            already, already_failed = skipped, skipped_failed
        else:  # a big study: count what is done in a first pass (a re-run), then generate the tasks again as they are sent
            pending = None
            if done and progress is not False:
                print(f"sweep: finding which of the {total:,} plans are done ({len(done):,} rows in {store.dir})", file=sys.stderr, flush=True)
            already = already_failed = 0
            for t in sweep.tasks() if done else ():
                if done.issuperset(t.keys):
                    already += 1
                    already_failed += not not_reached.isdisjoint(t.keys)
        stop = None if limit is None else already + (len(pending) if pending is not None else limit)
        # failures counted over the same plans as done: those of the runs before too
        bar = SweepProgress(total, already, failed=already_failed, interval=interval, stop=stop) if progress is not False else None
        source = iter(pending) if pending is not None else todo()
        if pending == [] or (pending is None and already >= total):
            # every row is there: no pool to spawn, no Ray instance to start (15 s on 2 cores) for nothing
            events: Iterator[Event] = iter(())
        else:
            events = local_engine(source, workers) if engine == "local" else ray_engine(source, workers, ray_address)
        try:
            for event in events:
                if event is INTERRUPTED:
                    raise KeyboardInterrupt
                task, rows = event
                if task is None:
                    store.tick()
                    if bar:
                        bar.tick()
                    continue
                ran += 1
                assert rows is not None  # (a finished task's)
                bad = any(r.get("outcome") != "reached" for r in rows)
                failed += bad
                store.add(rows)
                if on_rows is not None:
                    on_rows(rows)
                if bar:
                    bar.update(1, int(bad))
        except KeyboardInterrupt:
            interrupted = True
            raise
        finally:
            try:
                store.flush()  # the rows received first: the engine's teardown (Ray's shutdown) may not return
            finally:
                getattr(events, "close", lambda: None)()
    finally:
        if bar:
            bar.close()
        store.close()
    return SweepSummary(sweep.n_tasks, already, ran, failed, store.rows_written, store.files_written, time.monotonic() - t0, engine, workers, interrupted)
