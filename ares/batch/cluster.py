"""Dask (``dask.distributed``) for batches: the client, the lot map with a progress line,
and one huge stack accumulated on many workers.

Why Dask: it gives a local process cluster sized to the machine and the same code on a
cluster of many machines (``--scheduler tcp://host:8786``), with futures that complete in
any order, worker-side file reading and failure isolation -- the plumbing a hand-written
process pool would have to grow. Every worker must see the items' paths (a shared or
network file system for a multi-machine cluster) and the cache directory.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path


def make_client(scheduler: str | None = None, workers: int | None = None):
    """A ``distributed.Client``: to the scheduler at ``scheduler``, or to a new local cluster
    of ``workers`` single-threaded processes (default: one per core)."""
    import logging

    from distributed import Client, LocalCluster

    from ares.errors import HardwareError

    if scheduler:
        try:
            return Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise HardwareError(f"Dask scheduler {scheduler}: cannot connect ({exc})") from None
    import dask.config

    # Dask's workers default to MALLOC_TRIM_THRESHOLD_=65536, which turns off glibc's dynamic
    # mmap threshold: every frame-sized temporary is then a fresh mmap with page faults (the
    # stack accumulation ran 3x slower in a worker than in a plain process). Keep one BLAS
    # thread per worker, as ARES does in its own process.
    dask.config.set({"distributed.nanny.pre-spawn-environ": {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1,
                                                             "OPENBLAS_NUM_THREADS": 1}})
    n = workers or os.cpu_count() or 1
    # dashboard on any free port: two clusters side by side (tests, two lots) never clash
    # the workers log only what ends them: a task's error comes back through its future, and
    # the shutdown's "Failed to communicate with scheduler" is no news after a good lot
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=logging.CRITICAL)
    return Client(cluster)


QUIET_WHILE_CLOSING = ("distributed", "tornado", "asyncio")


def close_client(client) -> None:
    """Close the client and, when it started one, its local cluster -- with the loggers of
    Dask, Tornado and asyncio silent meanwhile: the ``CommClosedError ... Stream is closed``
    tracebacks a closing cluster logs about its own streams are not the user's concern."""
    import logging

    loggers = [logging.getLogger(n) for n in QUIET_WHILE_CLOSING]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        cluster = getattr(client, "cluster", None)
        client.close()
        if cluster is not None:
            cluster.close()
    finally:
        for lg, lv in zip(loggers, levels):
            lg.setLevel(lv)


def run_items(client, paths: list[str], cache_dir: str | None, progress=None, rerun_into: str | None = None,
              verify: bool = False) -> list[dict]:
    """Every item's result (``items.process``; with ``rerun_into``, run directories are first
    repeated there by ``items.rerun``) in the order given; ``progress(done, total, result)``
    after each completes (in completion order)."""
    from distributed import as_completed

    from ares.batch.items import RUN, kind_of, process, rerun

    futures = [client.submit(rerun, p, rerun_into, cache_dir, verify, pure=False)
               if rerun_into and kind_of(p) == RUN else client.submit(process, p, cache_dir, verify, pure=False)
               for p in paths]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[dict | None] = [None] * len(paths)
    for k, fut in enumerate(as_completed(futures), 1):
        try:
            r = fut.result()
        except Exception as exc:  # noqa: BLE001 -- a worker lost mid-task: the item failed, the lot goes on
            p = paths[index[fut.key]]
            r = {"item": p, "status": "error",
                 "error": f"{p}: worker failed ({type(exc).__name__}: {' '.join(str(exc).split())})"}
        out[index[fut.key]] = r
        if progress:
            progress(k, len(paths), r)
    return out  # type: ignore[return-value]


def progress_line(stream=None, log=None, quiet: bool = False):
    """``progress(done, total, result)``: a line on ``stream`` (done, failed, items/s, ETA;
    a new line every 5 % and at the end when the stream is not a terminal) and one line
    per item in the open text file ``log``."""
    stream = sys.stderr if stream is None else stream  # (the stderr of now, not of the import)
    t0 = time.perf_counter()
    failed = [0]
    tty = hasattr(stream, "isatty") and stream.isatty()
    step = [0]

    def show(done: int, total: int, r: dict) -> None:
        el = time.perf_counter() - t0
        failed[0] += r.get("status") == "error"
        what = "cached" if r.get("cached") else ("FAILED" if r.get("status") == "error" else "done")
        rate = done / el if el > 0 else float("inf")
        eta = (total - done) / rate if rate > 0 else float("nan")
        line = (f"{done}/{total} done, {failed[0]} failed, {rate:.2f} items/s, ETA {eta:.0f} s  "
                f"{Path(r['item']).name}: {what}")
        if log is not None:
            stamp = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime())
            log.write(f"{stamp} {line}" + (f" -- {r['error']}" if r.get("error") else "") + "\n")
            log.flush()
        if quiet:
            return
        if tty:
            stream.write("\r" + line.ljust(110)[:110] + ("\n" if done == total else ""))
        elif done == total or done * 20 // total > step[0]:
            step[0] = done * 20 // total
            stream.write(line + "\n")
        stream.flush()

    return show


# ------------------------------------------------------------------ one stack, many workers

def frame_count(spec: str) -> int:
    from ares.errors import InputError
    from ares.hardware.stackfiles import split_spec

    p, inner = split_spec(spec)
    if p.suffix.lower() == ".npy":
        import numpy as np

        a = np.load(p, mmap_mode="r", allow_pickle=False)
        return a.shape[0] if a.ndim == 3 else 1
    if p.suffix.lower() in (".h5", ".hdf5", ".hdf") and inner:
        import h5py

        with h5py.File(p, "r") as f:
            d = f[inner]
            return d.shape[0] if d.ndim == 3 else 1
    raise InputError(f"{spec}: a split stack must be a .npy or an HDF5 dataset (file.h5:/dataset)")


def accumulate_range(spec: str, start: int, stop: int):
    """Frames [start, stop) of the stack, read where the worker runs, in one
    ``StackAccumulator`` (exact integer sums)."""
    import numpy as np

    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.hardware.stackfiles import split_spec

    p, inner = split_spec(spec)
    if p.suffix.lower() == ".npy":
        a = np.load(p, mmap_mode="r", allow_pickle=False)
        frames = a[start:stop] if a.ndim == 3 else a[None]
        acc = StackAccumulator(frames.shape[1:])
        for f in frames:
            acc.add(np.asarray(f))
    else:
        import h5py

        with h5py.File(p, "r") as fh:
            d = fh[inner]
            acc = StackAccumulator(d.shape[1:])
            for i in range(start, stop):
                acc.add(d[i])
    return acc  # pickled as its sums only (StackAccumulator.__getstate__)


def split_accumulate(client, spec: str, chunks: int):
    """The stack accumulated in ``chunks`` frame ranges on the cluster's workers and merged
    in frame order: the same sums -- and the same decomposition, bit for bit -- as one pass."""
    n = frame_count(spec)
    chunks = max(1, min(chunks, n))
    bounds = [round(i * n / chunks) for i in range(chunks + 1)]
    futs = [client.submit(accumulate_range, spec, a, b, pure=False) for a, b in zip(bounds, bounds[1:]) if b > a]
    accs = client.gather(futs)
    acc = accs[0]
    for other in accs[1:]:
        acc.merge(other)
    return acc
