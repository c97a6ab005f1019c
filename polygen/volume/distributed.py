"""Partitioned volumes on Dask: partitions prepared once on the workers and kept there (issue 21).

Each partition of a :class:`~polygen.volume.partitioned.PartitionedVolume`
becomes a Dask **actor** (:class:`~polygen.volume.partitioned.PreparedPartition`
on a worker): the piece is read (or, for a split volume, sent) once, the
method is prepared there and kept; a query is one small call per partition,
and only the partition's triangles (global vertex keys, positions, triangles,
global cell ids) travel back to be stitched here.

Faults: when a worker is lost (its process killed, its machine gone), the
calls to its actors fail; the partitions it held are prepared again on the
workers that remain and the query is asked again, once. If that fails too,
or no worker remains, :class:`~polygen.volume.partitioned.PartitionError`
says which partition was lost: a query never returns part of a surface.

Dask is optional (``pip install polygen[distributed]``); this module imports
it when it is used, with a clear message when it is missing.
"""

from __future__ import annotations

import itertools
import time
import uuid

import numpy as np

from polygen.volume.partitioned import (PartitionError, PreparedPartition, _check_normals, check_partitions,
                                        stitch)
from polygen.volume.surface import check_value

__all__ = ["DaskPartitionedMethod", "prepare", "local_client", "require_distributed"]

#: how many times a query asks again after losing partitions (each time after preparing them again)
RETRIES = 1


def require_distributed():
    """``dask.distributed``, or :class:`PartitionError` saying how to install it."""
    try:
        import distributed
    except ImportError as e:
        raise PartitionError("partitioned volumes on Dask need dask.distributed, which is not installed: "
                             "pip install 'polygen[distributed]' (or run without a client)") from e
    return distributed


def prepare(pvol, field=None, method=None, *, client, **params):
    """Prepare ``method`` on every partition of ``pvol`` on the workers of ``client``, and keep them there.

    Returns a :class:`DaskPartitionedMethod` (``extract``, ``extract_many``,
    ``close``); ``client`` is a ``dask.distributed.Client`` (see
    :func:`local_client`).
    """
    return DaskPartitionedMethod(pvol, field, method, client=client, **params)


def local_client(n_workers=2, *, threads_per_worker=1, processes=True, scheduler=None):
    """A ``Client`` on a new ``LocalCluster`` (processes by default), or on the scheduler at ``scheduler``.

    Close it (``client.close()``, and ``client.cluster.close()`` for a local
    one) or use it as a context manager.
    """
    distributed = require_distributed()
    if scheduler is not None:
        return distributed.Client(scheduler)
    kwargs = {}
    if processes:
        # one numba thread per Dask thread: the workers share the machine's cores (two workers of two
        # numba threads each on two cores took 2x the work per partition, measured on 2M)
        kwargs["env"] = {"NUMBA_NUM_THREADS": str(int(threads_per_worker))}
    cluster = distributed.LocalCluster(n_workers=int(n_workers), threads_per_worker=int(threads_per_worker),
                                       processes=processes, dashboard_address=":0", **kwargs)
    return distributed.Client(cluster)


class DaskPartitionedMethod:
    """A method prepared on every partition, each kept on a Dask worker as an actor.

    Parameters
    ----------
    pvol : PartitionedVolume
    field, method : str, optional
    client : dask.distributed.Client, keyword-only
        Partitions go round-robin to its workers (sorted by address).
    **params
        The method's parameters.

    Attributes
    ----------
    preprocess_s : float
        Wall clock of preparing all partitions (reading, preparing, checking).
    prepare_s : list of float
        Each partition's own preparation time on its worker.
    infos : list of dict
        What each partition reported when prepared (:attr:`PreparedPartition.info`).
    placement : list of str
        The worker address of each partition.
    reprepared : int
        Partitions prepared again after a worker was lost.
    bytes_last : int
        Bytes of the arrays that came back for the last query.
    wait_last : float
        Seconds the last query waited for the partitions (calls, work, transfer; the stitch excluded).

    Notes
    -----
    One query at a time per object (calls to one actor run in order on its
    worker). The partitions are read once; nothing invalidates them.
    """

    def __init__(self, pvol, field=None, method=None, *, client, **params):
        require_distributed()
        self.client = client
        self.pieces = list(pvol.pieces)
        self.field, self.method, self.params = field, method, params
        self.reprepared = 0
        self.bytes_last = 0
        self.wait_last = 0.0
        t0 = time.perf_counter()
        workers = self._workers()
        self._futures = [None] * len(self.pieces)
        self.actors = [None] * len(self.pieces)
        self.placement = [None] * len(self.pieces)
        for i, w in zip(range(len(self.pieces)), itertools.cycle(workers)):
            self._start(i, w)
        try:
            infos = self._gather([a.get_info() for a in self.actors], what="prepare")
            self.infos = infos
            offsets, self.n_ids, self._shared = check_partitions(infos)
            self._offsets = offsets
            self.prepare_s = [i["preprocess_s"] for i in infos]
            self._gather([a.set_layout(o, self.n_ids, self._shared) for a, o in zip(self.actors, offsets)],
                         what="prepare")
        except _Lost as lost:
            self.close()
            raise PartitionError(f"partition {lost.index} ({self.pieces[lost.index].name!r}) was lost while being "
                                 f"prepared ({type(lost.cause).__name__}: {lost.cause}); prepare again") from lost
        self.preprocess_s = time.perf_counter() - t0

    # ------------------------------------------------------------ workers
    def _workers(self):
        workers = sorted(self.client.scheduler_info(n_workers=-1)["workers"]) if _takes_n_workers(self.client) \
            else sorted(self.client.scheduler_info()["workers"])
        if not workers:
            raise PartitionError("the Dask cluster has no workers")
        return workers

    def _start(self, i, worker):
        piece = self.pieces[i]
        key = f"polygen-partition-{i}-{uuid.uuid4().hex}"
        fut = self.client.submit(PreparedPartition, piece, i, self.field, self.method, self.params, actor=True,
                                 workers=[worker], allow_other_workers=True, key=key)
        self._futures[i] = fut
        self.actors[i] = fut.result()
        self.placement[i] = worker

    def _gather(self, calls, what):
        """Results of actor calls; an error from our code as it is, a lost worker as ``_Lost``."""
        out = []
        for i, c in enumerate(calls):
            try:
                out.append(c.result())
            except (PartitionError, ValueError):
                raise
            except Exception as e:  # noqa: BLE001  a worker lost: comm closed, actor gone, worker killed
                raise _Lost(i, e) from e
        return out

    def _calls(self, values, normals):
        """One call per partition; an actor whose worker is already known lost raises at once (as ``_Lost``)."""
        calls = []
        for i, a in enumerate(self.actors):
            try:
                calls.append(a.extract_many(values, normals))
            except Exception as e:  # noqa: BLE001  dask: "Worker holding Actor was lost"
                raise _Lost(i, e) from e
        return calls

    def _reprepare(self, lost):
        """Prepare the partitions ``lost`` (indices) again on the workers alive now."""
        alive = self._workers()
        # partitions whose worker is gone go too: their actors are lost with it
        lost = sorted(set(lost) | {i for i, w in enumerate(self.placement) if w not in alive})
        load = {w: 0 for w in alive}
        for i, w in enumerate(self.placement):
            if i not in lost and w in load:
                load[w] += 1
        for i in lost:
            w = min(alive, key=lambda a: (load[a], a))
            load[w] += 1
            self._start(i, w)
            self.actors[i].set_layout(self._offsets[i], self.n_ids, self._shared).result()
            self.reprepared += 1

    # ------------------------------------------------------------ queries
    def extract_many(self, values, *, normals="mean"):
        """The stitched surfaces of ``values`` (one call per partition for all values)."""
        values = [check_value(v) for v in values]
        _check_normals(normals)
        t0 = time.perf_counter()
        for attempt in range(RETRIES + 1):
            try:
                pieces = self._gather(self._calls(values, normals), what="query")
                break
            except _Lost as lost:
                if attempt == RETRIES:
                    raise PartitionError(
                        f"partition {lost.index} ({self.pieces[lost.index].name!r}) was lost again after being "
                        f"prepared again ({type(lost.cause).__name__}: {lost.cause}); no surface returned") from lost
                try:
                    self._reprepare([lost.index])
                except Exception as e:  # noqa: BLE001
                    raise PartitionError(f"partition {lost.index} ({self.pieces[lost.index].name!r}) was lost and "
                                         f"could not be prepared again ({type(e).__name__}: {e}); no surface "
                                         "returned") from e
        self.wait_last = time.perf_counter() - t0
        self.bytes_last = sum(_nbytes(p) for per in pieces for p in per)
        return [stitch(v, [per[j] for per in pieces], n_ids=self.n_ids, normals=normals)
                for j, v in enumerate(values)]

    def extract(self, value, *, normals="mean"):
        """The stitched surface ``S = value``."""
        return self.extract_many([value], normals=normals)[0]

    def close(self):
        """Release the actors (the partitions on the workers)."""
        for f in self._futures:
            if f is not None:
                f.release()
        self._futures = [None] * len(self.pieces)
        self.actors = [None] * len(self.pieces)


class _Lost(Exception):
    def __init__(self, index, cause):
        super().__init__(f"partition {index}: {cause!r}")
        self.index, self.cause = index, cause


def _nbytes(piece):
    return int(sum(v.nbytes for v in piece.values() if isinstance(v, np.ndarray)))


def _takes_n_workers(client):
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters
