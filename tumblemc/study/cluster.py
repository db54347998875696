"""The embedded dask cluster of a study: kernels warmed first, one single-threaded process per worker."""

from __future__ import annotations

import contextlib
import os
import signal
import time
import warnings
from collections.abc import Iterator
from typing import Any

from tumblemc.model.rows import TimeGrid, simulate_rows


def warm_kernels() -> float:
    """Compile (or load from the Numba cache) every kernel a study uses, in this process.

    Workers started afterwards load them from the cache instead of compiling each.
    """
    t0 = time.perf_counter()
    simulate_rows("cuboid", [{"preset": "paper", "freq_hz": 1000.0}], TimeGrid(periods=2.0))
    return time.perf_counter() - t0


def kernels_cached() -> bool:
    """Whether Numba's cache holds the batch kernel compiled from these sources.

    True: :func:`warm_kernels` loads it in seconds; False: it compiles (minutes on a cold
    cache). Reads Numba's cache index (a private API: False when it cannot be read).
    """
    from tumblemc.kernels.batch import run_batch

    try:
        return bool(run_batch._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 -- any failure to read it means: not known to be cached
        return False


def local_client(workers: int | None = None, dashboard: bool = False) -> Any:
    """A ``dask.distributed`` client on an embedded LocalCluster.

    One process per worker, one thread each (the kernels are single-threaded; processes
    avoid any GIL contention in the Python layer), Numba's cache warmed in this process
    first.

    ``dashboard=False``: the scheduler's HTTP server (which distributed always starts)
    listens on a free loopback port, so a busy port 8787 neither warns nor fails;
    ``dashboard=True``: the dashboard on 127.0.0.1:8787 (another free port if that one is
    taken), its address in ``client.dashboard_link``. Loopback only: the dashboard serves
    the scheduler's logs, workers and call stacks without a login; reach it from another
    machine through an SSH tunnel (``ssh -L 8787:127.0.0.1:8787 host``).
    """
    from distributed import Client, LocalCluster

    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    warm_kernels()
    n = int(workers or os.cpu_count() or 1)
    # worker processes inherit an ignored SIGINT: Ctrl-C reaches only this process, which
    # keeps the finished shards and shuts the cluster down (no traceback from each worker)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    address = "127.0.0.1:8787" if dashboard else "127.0.0.1:0"  # loopback only: the dashboard shows logs and call stacks without a login
    try:
        with warnings.catch_warnings():  # "Port 8787 is already in use ... instead": the link says where it is
            warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=address, silence_logs=50)
    finally:
        signal.signal(signal.SIGINT, previous)
    return Client(cluster)


@contextlib.contextmanager
def command_client(scheduler: str | None, workers: int | None, dashboard: bool = False) -> Iterator[Any]:
    """The dask client of a command: an existing scheduler's, an embedded local cluster's, or None (``workers == 0``: in process).

    On exit the client is closed, and the local cluster with it (a remote scheduler is left running).
    """
    client = None
    try:
        if scheduler:
            from distributed import Client

            client = Client(scheduler)
        elif workers != 0:
            client = local_client(workers, dashboard=dashboard)
        yield client
    finally:
        if client is not None:
            cluster = None if scheduler else getattr(client, "cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()


def n_workers(client: Any) -> int:
    """Workers of a dask client's cluster (at least 1)."""
    info = getattr(client, "scheduler_info", None)
    if info is None:  # pragma: no cover - a client-like object without that call
        return 1
    return max(1, len(info().get("workers", {})))
