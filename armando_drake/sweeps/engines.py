"""Where a sweep's tasks run: a local process pool, or a Ray cluster.

Both engines take a module-level function and a list of picklable tasks, run
the function on each task in parallel, and yield the results as they finish
(in completion order; every result says which task it belongs to). Sweeps
and data sets use them the same way; only the engine differs.

- :class:`InProcess`: one task after another in this process, for debugging.
- :class:`LocalPool`: ``workers`` at once on this machine. A function marked
  :func:`waits_on_child_process` (a sweep variant: it starts a world process and
  waits for it) runs in a thread of this process, so each of the ``workers``
  world processes is the pool's process; any other function (a data set shard)
  runs in a worker process of a ``concurrent.futures.ProcessPoolExecutor``
  started with ``spawn`` (no copy of a running Drake or thread state; as with any
  ``spawn`` pool, a script that uses it needs the ``if __name__ == "__main__":``
  guard).
- :class:`RayEngine`: Ray tasks (``ray.remote`` with ``num_cpus`` each),
  collected with ``ray.wait`` as they finish. ``address`` is ``auto`` (the
  cluster named by ``RAY_ADDRESS`` or the latest one started on this
  machine, else a new local instance), ``local`` (a new local instance) or
  a cluster address such as ``ray://head:10001`` or ``head:6379``. Every
  node needs this package installed (same Python, same version). Install
  Ray with ``pip install 'armando-drake[cluster]'``.
"""

from __future__ import annotations

import concurrent.futures
import logging
import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from armando_drake.sweeps.errors import SweepError


def waits_on_child_process(function: Callable) -> Callable:
    """Marks a task function that only starts a process and waits for it: threads suffice.

    Such a function may also carry ``on_interrupt``, a callable that stops the
    processes it started; the local pool calls it when the caller is interrupted.
    """
    function.waits_on_child_process = True
    return function


def available_cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


class InProcess:
    """Runs the tasks one after another in this process (for debugging and quick tests)."""

    name = "in-process"
    workers = 1

    def describe(self) -> str:
        return "this process, one task at a time"

    def map_unordered(self, function: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        for task in tasks:
            yield function(task)

    def close(self) -> None:
        pass

    def __enter__(self) -> InProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class LocalPool:
    """A pool of ``workers`` local processes (default: one per CPU)."""

    name = "local"

    def __init__(self, workers: int | None = None):
        if workers is not None and workers < 1:
            raise SweepError(f"--workers {workers} must be at least 1")
        self.workers = workers or available_cpus()

    def describe(self) -> str:
        return f"local pool of {self.workers} worker{'s' if self.workers > 1 else ''}"

    def map_unordered(self, function: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        tasks = list(tasks)
        if not tasks:
            return
        workers = min(self.workers, len(tasks))
        if getattr(function, "waits_on_child_process", False):
            pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers)
        else:
            pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=workers, mp_context=multiprocessing.get_context("spawn")
            )
        try:
            futures = [pool.submit(function, task) for task in tasks]
            for future in concurrent.futures.as_completed(futures):
                yield future.result()
        except BaseException:  # Ctrl-C, or the caller stopped early: stop the running tasks
            on_interrupt = getattr(function, "on_interrupt", None)
            if on_interrupt is not None:
                on_interrupt()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        pass

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class RayEngine:
    """Ray tasks of ``cpus_per_task`` CPUs each, at most ``workers`` in flight.

    Uses the Ray instance this process already started (``ray.init``) when
    there is one, else connects or starts one as ``address`` says (see the
    module docstring); a local instance it starts gets ``workers`` CPUs (default:
    all of this machine's), Ray's dashboard off, its files under ``temp_dir``
    when given, and is shut down by :meth:`close`.
    """

    name = "ray"

    def __init__(
        self,
        address: str = "auto",
        *,
        workers: int | None = None,
        cpus_per_task: float = 1.0,
        temp_dir: str | None = None,
    ):
        try:
            import ray
        except ImportError:
            raise SweepError(
                f"--ray {address}: Ray is not installed (pip install 'armando-drake[cluster]')"
            ) from None
        if workers is not None and workers < 1:
            raise SweepError(f"--workers {workers} must be at least 1")
        if cpus_per_task <= 0:
            raise SweepError(f"--cpus-per-task {cpus_per_task} must be positive")
        self._ray = ray
        self._owner = False
        self.cpus_per_task = cpus_per_task
        if not ray.is_initialized():
            common = {"include_dashboard": False, "log_to_driver": False}
            common["logging_level"] = logging.WARNING
            local = {"num_cpus": workers, "_temp_dir": temp_dir, **common}
            try:
                if address == "local":
                    ray.init(address="local", **local)
                elif address == "auto":
                    try:
                        ray.init(address="auto", **common)
                    except ConnectionError:  # no cluster running: a local one
                        ray.init(address="local", **local)
                else:
                    ray.init(address=address, **common)
            except ConnectionError as error:
                raise SweepError(f"--ray {address}: cannot connect: {error}") from None
            self._owner = True
        cpus = ray.cluster_resources().get("CPU", 1.0)
        capacity = max(1, int(cpus // cpus_per_task))
        self.workers = min(workers, capacity) if workers else capacity
        self.address = address

    def describe(self) -> str:
        cpus = self._ray.cluster_resources().get("CPU", 0.0)
        nodes = len([n for n in self._ray.nodes() if n.get("Alive")])
        return (
            f"Ray cluster ({nodes} node{'s' if nodes != 1 else ''}, {cpus:g} CPUs), "
            f"{self.workers} task{'s' if self.workers > 1 else ''} in flight"
        )

    def map_unordered(self, function: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        ray = self._ray
        remote = ray.remote(num_cpus=self.cpus_per_task)(function)
        waiting = list(tasks)
        waiting.reverse()  # pop() from the end submits in the given order
        running = []
        try:
            while waiting or running:
                while waiting and len(running) < self.workers:
                    running.append(remote.remote(waiting.pop()))
                done, running = ray.wait(running, num_returns=1)
                yield ray.get(done[0])
        finally:
            for ref in running:  # a KeyboardInterrupt in each task: runs stop cleanly
                ray.cancel(ref)

    def close(self) -> None:
        if self._owner and self._ray.is_initialized():
            self._ray.shutdown()
        self._owner = False

    def __enter__(self) -> RayEngine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def make_engine(
    ray: str | None = None,
    workers: int | None = None,
    cpus_per_task: float = 1.0,
    temp_dir: str | None = None,
):
    """The engine of the command-line options: Ray when ``ray`` names an address."""
    if ray:
        return RayEngine(ray, workers=workers, cpus_per_task=cpus_per_task, temp_dir=temp_dir)
    return LocalPool(workers)
