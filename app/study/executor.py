"""Where a study's independent runs execute: in this process one after another (the default), on
a Dask ``LocalCluster`` of worker processes started here, or on an existing Dask cluster.

A study hands its runs to one seam, ``executor.map(function, items, labels)``: ``function`` is
called once per item (on a worker it and the item are pickled, so both are plain data and
module-level functions or picklable objects), the results come back **in the order of the
items**, whatever order the runs finish in, and ``progress(label)`` is called as each run
completes.  The same items give the same results everywhere: each run is a deterministic
computation from its item.

* ``serial()`` (``Serial``): a plain loop in this process.
* ``local_cluster(workers)``: ``dask.distributed.LocalCluster`` with ``workers`` processes of
  one thread each (``--workers N``).
* ``cluster(address)``: a running scheduler, e.g. ``tcp://10.0.0.5:8786`` (``--scheduler``),
  started with dask's own command line (``dask scheduler``; ``dask worker tcp://...`` on each
  machine; the workers must be able to import this program).

Failures: a run whose worker dies is run again on another worker by the scheduler (up to
``distributed.scheduler.allowed-failures`` deaths, 3 by default), and a run that raises is
retried ``RETRIES`` times.  A run still failing after that is *lost*: the other runs finish,
then ``LostRunsError`` names every lost run and why, with the results of the others; nothing is
dropped silently.  In this process (``Serial``) a run's error is raised as it is.
``prepare(function, *arguments)`` runs once in every worker process (and here for ``Serial``)
before timing matters, e.g. to compile kernels.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

ProgressCallback = Callable[[str], None]

RETRIES = 2
"""Times a run that raised is run again before it counts as lost."""


class ExecutorError(ValueError):
    """A cluster that cannot be used (bad address, no scheduler there, bad worker count)."""


class LostRunsError(RuntimeError):
    """Runs that failed after their retries.  ``lost`` maps each lost run's label to the reason;
    ``results`` holds every result in item order, None where the run was lost."""

    def __init__(self, lost: dict[str, str], results: list[Any]) -> None:
        self.lost = lost
        self.results = results
        names = "; ".join(f"{label}: {reason}" for label, reason in lost.items())
        super().__init__(f"{len(lost)} of {len(results)} runs lost after retries ({names})")


def _labels(items: Sequence[Any], labels: Sequence[str] | None) -> list[str]:
    if labels is None:
        return [f"run {index + 1}" for index in range(len(items))]
    if len(labels) != len(items):
        raise ValueError(f"{len(labels)} labels for {len(items)} runs")
    return [str(label) for label in labels]


class Serial:
    """Every run in this process, one after another (the default executor)."""

    description = "serial, in this process"
    workers = 1

    def map(self, function: Callable[[Any], Any], items: Sequence[Any],
            labels: Sequence[str] | None = None,
            progress: ProgressCallback | None = None) -> list[Any]:
        """``[function(item) for item in items]``, calling ``progress(label)`` after each."""
        names = _labels(items, labels)
        results = []
        for item, label in zip(items, names, strict=True):
            results.append(function(item))
            if progress:
                progress(label)
        return results

    def prepare(self, function: Callable[..., Any], *arguments: Any) -> None:
        function(*arguments)

    def close(self) -> None:
        pass


class DaskExecutor:
    """Runs submitted to a ``dask.distributed`` client (a local cluster or a remote one)."""

    def __init__(self, client: Any, cluster: Any = None, description: str = "dask") -> None:
        self.client = client
        self.cluster = cluster
        self.description = description

    @property
    def workers(self) -> int:
        return len(self.client.scheduler_info().get("workers", {}))

    def map(self, function: Callable[[Any], Any], items: Sequence[Any],
            labels: Sequence[str] | None = None,
            progress: ProgressCallback | None = None) -> list[Any]:
        """Submit every run, gather the results in item order as they complete; raise
        ``LostRunsError`` after the others finished if any run was lost."""
        from dask.distributed import as_completed

        names = _labels(items, labels)
        futures = [self.client.submit(function, item, pure=False, retries=RETRIES)
                   for item in items]
        index_of = {future.key: index for index, future in enumerate(futures)}
        results: list[Any] = [None] * len(items)
        lost: dict[str, str] = {}
        for future in as_completed(futures):
            index = index_of[future.key]
            try:
                results[index] = future.result()
            except Exception as error:  # noqa: BLE001 - reported by name, never dropped
                lost[names[index]] = f"{type(error).__name__}: {error}"
            if progress:
                progress(names[index] + (" (lost)" if names[index] in lost else ""))
        if lost:
            raise LostRunsError(lost, results)
        return results

    def prepare(self, function: Callable[..., Any], *arguments: Any) -> None:
        self.client.run(function, *arguments)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def serial() -> Serial:
    return Serial()


def local_cluster(workers: int) -> DaskExecutor:
    """A ``LocalCluster`` of ``workers`` processes, one thread each, on this machine."""
    if isinstance(workers, bool) or int(workers) != workers or workers < 1:
        raise ExecutorError(f"--workers must be a whole number >= 1, got {workers!r}")
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                           dashboard_address=None)
    return DaskExecutor(Client(cluster), cluster,
                        f"dask LocalCluster, {int(workers)} worker process(es)")


def cluster(address: str, timeout: float = 10.0) -> DaskExecutor:
    """The running Dask cluster whose scheduler is at ``address`` (tcp://HOST:PORT)."""
    text = str(address).strip()
    if not text.startswith(("tcp://", "tls://", "ws://", "wss://", "inproc://")) or ":" not in text[6:]:
        raise ExecutorError(f"--scheduler must look like tcp://HOST:PORT, got {address!r}")
    from dask.distributed import Client

    try:
        client = Client(text, timeout=timeout)
    except (OSError, TimeoutError) as error:
        raise ExecutorError(f"no Dask scheduler answered at {text} ({error})") from None
    return DaskExecutor(client, None, f"dask cluster at {text}")


@contextlib.contextmanager
def executor_for(workers: int | None = None, scheduler: str | None = None
                 ) -> Iterator[Serial | DaskExecutor]:
    """The executor the options ask for (neither: serial), closed on leaving the block."""
    if workers is not None and scheduler is not None:
        raise ExecutorError("give --workers or --scheduler, not both")
    if scheduler is not None:
        chosen: Serial | DaskExecutor = cluster(scheduler)
    elif workers is not None:
        chosen = local_cluster(workers)
    else:
        chosen = serial()
    try:
        yield chosen
    finally:
        chosen.close()
