"""Partitioned volumes on Dask: partitions prepared once on the workers and kept there.

Each partition of a :class:`~polygen.volume.partitioned.PartitionedVolume`
becomes a Dask **actor** (:class:`SharedMemoryPartition`, a
:class:`~polygen.volume.partitioned.PreparedPartition` on a worker): the
piece is read (or, for a split volume, sent) once, the method is prepared
there and kept. A query asks every partition for its pieces (global vertex
keys, positions, normals of its own vertices, seam marks, triangles, global
cell ids) and stitches them in one of two places (``stitch_on``):

* **on the client** (the default when every worker runs on the client's
  machine): the values are cut into chunks, and each chunk is stitched in
  two phases. First every partition extracts the chunk's surfaces and
  reports their vertex and triangle counts and their seam vertices (a few
  per thousand); the client lays out the stitched surfaces
  (:func:`~polygen.volume.partitioned.rows_layout`: only seam vertices are
  matched, every other row is an offset) in one POSIX **shared-memory**
  block per chunk; then every partition writes its rows of every stitched
  array (global keys, positions, normals of its own vertices, triangles
  renumbered, global cell ids) straight into that block, and the client
  makes the seam vertices' normals. The surfaces' arrays are views on the
  block: nothing is copied after the workers wrote it. A block whose
  surfaces are all gone is written again by a later chunk (both sides keep
  it mapped: its pages are not faulted in and zeroed again, as ``malloc``
  reuses a single volume's freed surfaces). The workers run up to
  ``AHEAD`` chunks ahead of the client's layout. These calls do not go
  through Dask: each partition's actor listens on a Unix socket of its own
  (``open_channel``) and a thread there answers the client's calls in
  order -- a Dask actor call's round trip through both event loops cost
  30 times as much (3-4 ms against 0.11 ms for a call to each of two
  partitions, measured on 2 cores), which a query one value at a time
  pays twice. Over TCP instead (a worker elsewhere, or
  no shared memory here), every partition's pieces travel in Dask's
  messages and are merged here (:func:`~polygen.volume.partitioned.stitch`).
* **on the workers**: one small task per partition and chunk of values,
  which asks the partition's actor on its own worker for its pieces; the
  pieces are merged pairwise up a tree of neighbouring partitions
  (:func:`~polygen.volume.partitioned.reduce_tree`, Morton order: each
  merge removes the seam vertices between its two sides), the root makes
  the seam vertices' normals, and only the stitched surface travels to the
  client. Neighbouring partitions are placed on the same worker (blocks of
  the Morton order), so the lower merges move nothing between workers; the
  values are cut into as many chunks as there are workers and each chunk's
  root merge runs on another worker, so the stitch is shared out.

Faults: when a worker is lost (its process killed, its machine gone), the
calls to its actors fail; the partitions it held are prepared again on the
workers that remain and the query is asked again, once. If that fails too,
or no worker remains, :class:`~polygen.volume.partitioned.PartitionError`
says which partition was lost: a query never returns part of a surface.
Shared-memory blocks of a failed query are unlinked by the client, by
name, once all its calls have answered or failed.

Dask is optional (``pip install polygen[distributed]``); this module imports
it when it is used, with a clear message when it is missing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import itertools
import mmap
import os
import threading
import time
import uuid

import numpy as np

from polygen.volume.partitioned import (PartitionError, PreparedPartition, _check_normals, check_partitions,
                                        finish, finish_rows, merge, reduce_tree, rows_arrays, rows_layout, stitch)
from polygen.volume.surface import check_value

__all__ = ["DaskPartitionedMethod", "prepare", "local_client", "require_distributed"]

#: how many times a query asks again after losing partitions (each time after preparing them again)
RETRIES = 1
#: chunks a query's values are cut into when the client stitches (``DaskPartitionedMethod.chunk_values``
#: unset): the client stitches one chunk while the workers extract the next
CHUNKS = 5
#: values per chunk when the workers write the stitched arrays (shared memory): the client's share is small, so
#: no chunk needs to be short, and each chunk costs two calls per partition (Dask's messages). 2M, 20 values, all
#: processes' CPU against the single volume's (load ~3.3): 4 chunks 1.63-1.73x, 2 chunks 1.56-1.57x, 1 chunk
#: 1.47-1.48x. Longer sweeps go in chunks of this many (a worker holds up to ``AHEAD`` chunks' surfaces)
DIRECT_CHUNK_VALUES = 20
#: chunks whose extraction is asked for before the client lays out the first of them (through shared memory):
#: a worker extracts the next chunk while the client lays out and finishes the one before
AHEAD = 2
#: free shared-memory blocks kept for later queries: up to this many times the most bytes one query's blocks took
KEEP_FREE = 2
#: glibc's settings for the worker processes of :func:`local_client` (set before they start: see there)
WORKER_MALLOC = {"MALLOC_MMAP_THRESHOLD_": 32 << 20, "MALLOC_TRIM_THRESHOLD_": 1 << 30}
#: how long a new query waits for a cluster with no worker listed to list one
WORKERS_TIMEOUT_S = 10
#: how long a query that failed waits for its other calls before unlinking their shared-memory blocks
SWEEP_TIMEOUT_S = 60


def require_distributed():
    """``dask.distributed``, or :class:`PartitionError` saying how to install it."""
    try:
        import distributed
    except ImportError as e:
        raise PartitionError("partitioned volumes on Dask need dask.distributed, which is not installed: "
                             "pip install 'polygen[distributed]' (or run without a client)") from e
    return distributed


def prepare(pvol, field=None, method=None, *, client, stitch_on="auto", **params):
    """Prepare ``method`` on every partition of ``pvol`` on the workers of ``client``, and keep them there.

    Returns a :class:`DaskPartitionedMethod` (``extract``, ``extract_many``,
    ``close``); ``client`` is a ``dask.distributed.Client`` (see
    :func:`local_client`).
    """
    return DaskPartitionedMethod(pvol, field, method, client=client, stitch_on=stitch_on, **params)


def local_client(n_workers=2, *, threads_per_worker=1, processes=True, scheduler=None):
    """A ``Client`` on a new ``LocalCluster`` (processes by default), or on the scheduler at ``scheduler``.

    Close it (``client.close()``, and ``client.cluster.close()`` for a local
    one) or use it as a context manager.
    """
    distributed = require_distributed()
    if scheduler is not None:
        return distributed.Client(scheduler)
    # one numba thread per Dask thread (two workers of two numba threads each on two cores took 2x the
    # work per partition, measured on 2M): set by the workers' own calls (:func:`_as_dask_threads`), not
    # through NUMBA_NUM_THREADS. numba re-reads that variable at every compilation and refuses a value
    # other than the one its threads were launched with: given to the workers with ``env=`` it made the
    # first kernel compiled in a worker fail (a fresh install: nothing cached), and given before the
    # spawn it stays in this process's environment (the nanny sets it here) and breaks this process's
    # next compilation instead
    import dask

    # no work stealing: a query's tasks are placed beside the partitions and pieces they read (stolen, they
    # fetched the pieces across workers: measured on data 4 in 4 partitions, 86 % of the pieces moved, not 50 %).
    # Quieter book-keeping: the statistical profiler off, the event-loop tick and system monitor slower -- on
    # a 2-core machine they cost CPU the queries need (measured idle: the client process with the scheduler
    # 0.038 -> 0.018 s of CPU per second, each worker 0.028 -> 0.009)
    # glibc in the worker processes: Dask starts them with MALLOC_TRIM_THRESHOLD_=65536 (freed memory goes back to
    # the kernel at once), and a surface's arrays of a few MB then come from fresh pages at every query, faulted
    # in and zeroed again (10M in 2 partitions: ~118,000 page faults per 20-value sweep, the method's outputs). A
    # fixed mmap threshold of 32 MiB (glibc's largest dynamic one) and a trim threshold of 1 GiB keep them for
    # the next query: ~0 faults, the workers' CPU per sweep 1.70-1.85 -> 1.51-1.61 s (measured at load 3-3.8)
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {}) | WORKER_MALLOC
    with dask.config.set({"distributed.scheduler.work-stealing": False, "distributed.worker.profile.enabled": False,
                          "distributed.admin.tick.interval": "200ms",
                          "distributed.admin.system-monitor.interval": "1s",
                          "distributed.nanny.pre-spawn-environ": environ}):
        cluster = distributed.LocalCluster(n_workers=int(n_workers), threads_per_worker=int(threads_per_worker),
                                           processes=processes, dashboard_address=":0")
    return distributed.Client(cluster)


def _shared_memory_ok():
    """Whether POSIX shared memory works here (``multiprocessing.shared_memory`` on Linux/macOS)."""
    try:
        from multiprocessing import shared_memory

        shm = shared_memory.SharedMemory(create=True, size=64)
    except (ImportError, OSError):
        return False
    shm.close()
    shm.unlink()
    return True


def _workers_are_local(client):
    """Whether every worker of ``client`` runs on this machine (loopback, in-process or this host's name)."""
    import socket
    from urllib.parse import urlsplit

    here = {"127.0.0.1", "localhost", "::1", socket.gethostname()}
    with contextlib.suppress(OSError):
        here.add(socket.gethostbyname(socket.gethostname()))
    for address in client.scheduler_info()["workers"]:
        if address.startswith("inproc://"):
            continue
        if urlsplit(address).hostname not in here:
            return False
    return True


class DaskPartitionedMethod:
    """A method prepared on every partition, each kept on a Dask worker as an actor.

    Parameters
    ----------
    pvol : PartitionedVolume
    field, method : str, optional
    stitch_on : {"auto", "workers", "client"}, keyword-only
        Where the pieces are stitched: merged up the tree on the workers
        (only stitched surfaces reach the client), or all sent to the
        client and stitched there (:func:`~polygen.volume.partitioned.stitch`);
        the same arrays either way. ``"auto"`` (the default) stitches on the
        client when every worker runs on this machine (a ``LocalCluster``:
        nothing is gained by moving pieces between processes that share
        the client's cores -- measured 1.3-2.3x slower on 2 cores,
        ``benchmarks/results/partitioned.md``) and on the workers otherwise.
    client : dask.distributed.Client, keyword-only
        Partitions go to its workers (sorted by address) in blocks of
        consecutive partitions (neighbours on one worker).
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
        Bytes of the arrays that came back to the client for the last query
        (the stitched surfaces: vertices, normals, triangles and cell ids as
        int32, keys; with ``stitch_on="client"``, the pieces).
    bytes_workers_last : int
        Bytes of pieces the last query moved from one worker to another
        (merge inputs made elsewhere).
    bytes_pieces_last : int
        Bytes of all the partitions' pieces of the last query (moved or not).
    wait_last : float
        Seconds the last query waited for its surfaces (calls, work, merges, transfer).
    transport : {"shared-memory", "tcp"}
        How a stitch on the client gets the partitions' rows: written by the
        workers straight into the stitched surfaces' arrays in POSIX shared
        memory when every worker runs on this machine (and it works here),
        else as pieces in Dask's messages, merged here.
    chunk_values : int or None
        Values per chunk when the client stitches (default: through shared
        memory, at most ``DIRECT_CHUNK_VALUES``; over TCP, the values in
        ``CHUNKS`` chunks, the last cut in halves down to one value): the
        workers extract a chunk while the client lays out (or stitches) and
        finishes the one before.
    phases_last : dict
        Client stitch only: ``wait_s`` (waiting for the workers) and
        ``stitch_s`` (laying out, finishing) of the last query; through
        shared memory also ``calls``, each call's ``timing`` from its worker
        (``kind`` ``"find"`` or ``"write"``, ``start``, ``end`` on
        ``time.perf_counter``'s clock -- the machine's monotonic clock on
        Linux --, ``cpu_s``, ``surface_cpu_s``, ``piece_cpu_s``) with its
        ``chunk``, ``partition`` and the client's ``sent``, ``waited`` and
        ``gathered``.
    blocks_last : list of str
        The shared-memory blocks the last query wrote (one per chunk; every
        name unlinked once both sides mapped it, or when the query raises:
        the surfaces' arrays keep their block mapped).
    blocks_made_last : int
        How many of them were made for it (the others were written again:
        their former surfaces were gone).

    Notes
    -----
    One query at a time per object (calls to one actor run in order on its
    worker). The partitions are read once; nothing invalidates them.
    """

    def __init__(self, pvol, field=None, method=None, *, client, stitch_on="auto", **params):
        require_distributed()
        if stitch_on not in ("auto", "workers", "client"):
            raise PartitionError(f"stitch_on must be 'auto', 'workers' or 'client'; got {stitch_on!r}")
        if stitch_on == "auto":
            stitch_on = "client" if _workers_are_local(client) else "workers"
        self.stitch_on = stitch_on
        self.client = client
        # pieces stitched on the client come through shared memory when every worker is on this machine
        self.transport = "shared-memory" if _shared_memory_ok() and _workers_are_local(client) else "tcp"
        self.pieces = list(pvol.pieces)
        self.field, self.method, self.params = field, method, params
        self.reprepared = 0
        self.bytes_last = 0
        self.bytes_workers_last = 0
        self.bytes_pieces_last = 0
        self.wait_last = 0.0
        self.phases_last = {}
        self.blocks_last = []
        self.blocks_made_last = 0
        self.chunk_values = None
        # shared-memory blocks, kept mapped here and on the workers: name -> [mapping, size, free, last query]; a
        # block is free once no surface views it (a finalizer on its root array puts its name in _freed)
        self._blocks = {}
        self._freed = []
        self._query_count = 0  # queries through shared memory so far (the blocks' last use)
        self._most_bytes = 0  # the most bytes of blocks one query used (the free blocks kept: _keep_free)
        self._forget = []  # blocks given up here, to be unmapped by the workers at their next write
        t0 = time.perf_counter()
        workers = self._workers()
        self._futures = [None] * len(self.pieces)
        self.actors = [None] * len(self.pieces)
        self.channels = [None] * len(self.pieces)
        self.placement = [None] * len(self.pieces)
        k = len(self.pieces)
        for i in range(k):  # blocks of neighbours: partition i on worker i * W // k
            self._start(i, workers[i * len(workers) // k])
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
        def listed():
            info = (self.client.scheduler_info(n_workers=-1) if _takes_n_workers(self.client)
                    else self.client.scheduler_info())
            return sorted(info["workers"])

        workers = listed()
        if not workers:
            # the client's copy of the scheduler's identity is refreshed every few seconds: just after a new
            # cluster started it can list none (seen once on a new LocalCluster); ask the scheduler itself
            with contextlib.suppress(Exception):
                self.client.wait_for_workers(1, timeout=WORKERS_TIMEOUT_S)
            workers = listed()
        if not workers:
            raise PartitionError(f"the Dask cluster has no workers (waited {WORKERS_TIMEOUT_S} s for one)")
        return workers

    def _start(self, i, worker):
        piece = self.pieces[i]
        if not hasattr(piece, "path"):  # a piece in memory: sent to its worker as data, not inside the task graph
            piece = self.client.scatter(piece, workers=[worker], hash=False)
        key = f"polygen-partition-{i}-{uuid.uuid4().hex}"
        fut = self.client.submit(SharedMemoryPartition, piece, i, self.field, self.method, self.params, actor=True,
                                 workers=[worker], allow_other_workers=True, key=key)
        self._futures[i] = fut
        self.actors[i] = fut.result()
        self.placement[i] = worker
        if self.channels[i] is not None:
            self.channels[i].close()
            self.channels[i] = None
        if self.transport == "shared-memory":
            # the queries' calls over a connection of their own (see _Channel): a Dask actor call costs a round
            # trip through both event loops (measured on this 2-core machine, load ~7: 3.1-4.0 ms for a call to
            # each of two actors, 1.9 ms of the client's CPU; the same over such a connection 0.11 ms, 0.05 ms)
            authkey = os.urandom(16)
            self.channels[i] = _Channel(self.actors[i].open_channel(authkey).result(), authkey, i)

    def _call(self, i, name, *args):
        """Partition ``i``'s method ``name`` called on its worker: over its channel where it has one, else through
        its actor; an object whose ``result(timeout=None)`` answers."""
        if self.channels[i] is not None:
            return self.channels[i].call(name, *args)
        return getattr(self.actors[i], name)(*args)

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
    def _submit_query(self, values, normals):
        """The tasks of one query: per chunk of values, a leaf per partition, the merges, the root's finish."""
        submit, uid = self.client.submit, uuid.uuid4().hex
        n_chunks = max(1, min(len(set(self.placement)), len(values)))
        chunks = [[values[j] for j in idx] for idx in np.array_split(np.arange(len(values)), n_chunks)]
        # where each chunk's root merge runs (as combine below places it)
        root_w = [reduce_tree(self.placement, lambda x, y, c=c: x if x == y or c % 2 == 0 else y)
                  for c in range(n_chunks)]
        # a worker first makes the pieces that another worker's root waits for, then those its own roots
        # need (submitted in that order, and prioritised so); merges and finishes go before a ready leaf
        leaves = [[None] * len(self.actors) for _ in chunks]
        for first in (True, False):
            for c, vals in enumerate(chunks):
                for i, (a, f, w) in enumerate(zip(self.actors, self._futures, self.placement)):
                    if (w != root_w[c]) == first:
                        leaves[c][i] = submit(_leaf, a, f.key, vals, normals, workers=[w], allow_other_workers=True,
                                              pure=False, priority=1 if first else 0,
                                              key=f"polygen-leaf-{i}-{c}-{uid}")
        roots = []
        for c, vals in enumerate(chunks):
            count = itertools.count()

            def combine(x, y, c=c, count=count):
                # on one of the two sides' workers; across workers, the root of odd chunks on the right side's
                (fx, wx), (fy, wy) = x, y
                w = wx if wx == wy or c % 2 == 0 else wy
                return submit(_merge, self.n_ids, fx, fy, workers=[w], allow_other_workers=True, pure=False,
                              priority=2, key=f"polygen-merge-{c}-{next(count)}-{uid}"), w

            root, w = reduce_tree(list(zip(leaves[c], self.placement)), combine)
            roots.append(submit(_finish, vals, self.n_ids, normals, root, workers=[w], allow_other_workers=True,
                                pure=False, priority=2, key=f"polygen-finish-{c}-{uid}"))
        return leaves, roots

    def _run_on_client(self, values, normals):
        """All pieces sent here and stitched here, chunk after chunk of values (over TCP; see :meth:`_run_direct`
        for shared memory). Every chunk's calls are sent at once; each partition answers them in order, and the
        client stitches chunk ``c`` while the workers extract the next."""
        if self.transport == "shared-memory":
            return self._run_direct(values, normals)
        chunks = _chunked(values, self.chunk_values)
        calls = []
        for c in range(len(chunks)):
            row = []
            for i, a in enumerate(self.actors):
                try:
                    row.append(a.extract_many(chunks[c], normals))
                except Exception as e:  # noqa: BLE001  dask: "Worker holding Actor was lost"
                    raise _Lost(i, e) from e
            calls.append(row)
        surfaces, made = [], 0
        self.phases_last = {"wait_s": 0.0, "stitch_s": 0.0}
        for c, chunk in enumerate(chunks):
            t0 = time.perf_counter()
            pieces = self._gather(calls[c], what="query")
            t1 = time.perf_counter()
            made += sum(_nbytes(p) for per in pieces for p in per)
            surfaces += [stitch(v, [per[j] for per in pieces], n_ids=self.n_ids, normals=normals)
                         for j, v in enumerate(chunk)]
            self.phases_last["wait_s"] += t1 - t0
            self.phases_last["stitch_s"] += time.perf_counter() - t1
        return surfaces, 0, made

    def _run_direct(self, values, normals):
        """The stitch on the client through shared memory, chunk after chunk, in two phases per chunk.

        ``find``: every partition extracts the chunk's surfaces and keeps
        them, answering their counts and seam vertices; the client lays out
        the stitched surfaces (:func:`~polygen.volume.partitioned.rows_layout`)
        in a block made for the chunk; ``write``: every partition writes its
        rows into the block; the client finishes the surfaces (seam normals)
        on views of the block. The finds of ``AHEAD`` chunks are asked for
        first, then each layout sends the chunk's writes and the find of the
        chunk ``AHEAD`` further, and the chunk before is finished: each
        partition answers its calls in order, so it extracts the next chunk
        while the client lays out and finishes.
        """
        chunks = _direct_chunks(values, self.chunk_values)
        nc = len(chunks)
        uid = uuid.uuid4().hex[:16]
        finds, writes, held, names = [None] * nc, [None] * nc, [None] * nc, []  # names: blocks made here
        used, block_of = set(), [None] * nc
        sent = {}
        phases = self.phases_last = {"wait_s": 0.0, "stitch_s": 0.0, "calls": []}
        made = [0]

        def send(c, rows, ask):
            rows[c] = row = []  # the calls sent so far, for the clean-up if one cannot be sent
            for i, a in enumerate(self.actors):
                try:
                    row.append(ask(i, a))
                except Exception as e:  # noqa: BLE001  dask: "Worker holding Actor was lost"
                    raise _Lost(i, e) from e
            sent[rows is finds, c] = time.perf_counter()

        def find(c):
            send(c, finds, lambda i, a: self._call(i, "find_shared", chunks[c], normals, (uid, c)))

        def gather(c, rows):
            t0 = time.perf_counter()
            answers = self._gather(rows[c], what="query")
            t1 = time.perf_counter()
            phases["wait_s"] += t1 - t0
            phases["calls"] += [a["timing"] | {"chunk": c, "partition": i, "sent": sent[rows is finds, c],
                                               "waited": t0, "gathered": t1} for i, a in enumerate(answers)]
            return answers, t1, time.thread_time()

        def lay_out(c):
            answers, t1, c1 = gather(c, finds)
            found = [[a["found"][j] for a in answers] for j in range(len(chunks[c]))]  # per value, per partition
            layouts = [rows_layout(f) for f in found]
            offsets, size = [], 0
            for lay in layouts:
                offsets.append(size)
                size += rows_arrays(lay, normals, empty=False)[1]
            name, block, fresh = self._take_block(max(size, 64), f"polygen-{uid}-{c}")
            used.add(name)
            block_of[c] = name
            if fresh:
                names.append(name)
            self.blocks_last.append(name)
            made[0] += size + sum(f["seam"].nbytes + f["seam_keys"].nbytes for per in found for f in per)
            forget, self._forget = self._forget, []
            send(c, writes, lambda i, a: self._call(
                i, "write_shared", (uid, c), name,
                [{"n_vertices": lay["n_vertices"], "n_triangles": lay["n_triangles"], "offset": o,
                  "plan": lay["plans"][i]} for lay, o in zip(layouts, offsets)], normals, forget))
            dt, dc = time.perf_counter() - t1, time.thread_time() - c1
            held[c] = (found, layouts, offsets, block, dt / len(chunks[c]), dc / len(chunks[c]))
            phases["stitch_s"] += dt

        def finish_chunk(c):
            answers, t1, c1 = gather(c, writes)
            found, layouts, offsets, block, dt, dc = held[c]
            held[c] = None
            _unlink_quietly(block_of[c])  # every side mapped it: the name can go (made here or not)
            out = []
            for j, v in enumerate(chunks[c]):
                arrays, _ = rows_arrays(layouts[j], normals, buf=block, offset=offsets[j])
                t0, c0 = time.perf_counter(), time.thread_time()
                out.append(finish_rows(v, arrays, layouts[j], found[j], [a["written"][j] for a in answers],
                                       n_ids=self.n_ids, normals=normals, t0=t0 - dt, c0=c0 - dc))
            phases["stitch_s"] += time.perf_counter() - t1
            return out

        ok = False
        try:
            for c in range(min(AHEAD, nc)):
                find(c)
            surfaces = []
            for c in range(nc):
                lay_out(c)
                if c + AHEAD < nc:
                    find(c + AHEAD)
                if c:
                    surfaces += finish_chunk(c - 1)
            if nc:
                surfaces += finish_chunk(nc - 1)
            ok = True
            self.blocks_made_last = len(names)
            return surfaces, 0, made[0]
        finally:
            held = None
            if ok:
                self._keep_free(used)
            else:  # the workers may have lost their mappings: every block goes
                self._drop_blocks(lambda n, b: True)
                self._sweep([row for row in finds + writes if row is not None], [names])

    def _take_block(self, size, name):
        """A block of at least ``size`` bytes whose surfaces are gone (the smallest), or a new one named
        ``name``: ``(name, root, fresh)``, ``root`` a uint8 array on the whole block whose surfaces view it."""
        import weakref

        self._mark_freed()
        free = [(b[1], n) for n, b in self._blocks.items() if b[2] and b[1] >= size]
        if free:
            name = min(free)[1]
            b = self._blocks[name]
            fresh = False
        else:
            size += size // 8  # room for a chunk a little larger next time
            size = -(-size // 65536) * 65536
            b = self._blocks[name] = [_new_block(name, size), size, False, 0]  # mapping, bytes, free, last query
            fresh = True
        b[2] = False
        root = np.frombuffer(b[0], np.uint8)
        weakref.finalize(root, self._freed.append, name).atexit = False
        return name, root, fresh

    def _mark_freed(self):
        while self._freed:
            b = self._blocks.get(self._freed.pop())
            if b is not None:
                b[2] = True

    def _keep_free(self, used):
        """After a query that used the blocks ``used``: the free blocks it did not use are kept for later queries
        while they total no more than the most bytes one query's blocks have taken so far, the least recently
        used given up first (``KEEP_FREE`` times those bytes: a sweep of one kind keeps the blocks of the other
        kind's too -- the most recent block of an ``extract_many`` alone is as large as the free blocks of a whole
        sweep one value at a time, so a bound of 1x gave those up).

        (Each query giving up every free block it did not use made a sweep one value at a time after an
        ``extract_many``, or the reverse, make all its blocks anew, their pages faulted in again on the workers:
        10M in 2 partitions, the 20 values one at a time cost 2003 ms of CPU against 1128 ms for ``extract_many``.)
        The memory kept free is then at most ``KEEP_FREE`` times what the largest query held while its surfaces
        lived.
        """
        self._mark_freed()
        self._query_count += 1
        stamp = self._query_count
        for n in used:
            if n in self._blocks:
                self._blocks[n][3] = stamp
        self._most_bytes = max(self._most_bytes, sum(self._blocks[n][1] for n in used
                                                                    if n in self._blocks))
        free = sorted((b[3], n) for n, b in self._blocks.items() if b[2] and n not in used)
        total = sum(self._blocks[n][1] for _, n in free)
        drop = set()
        for _, n in free:  # oldest first
            if total <= KEEP_FREE * self._most_bytes:
                break
            drop.add(n)
            total -= self._blocks[n][1]
        if drop:
            self._drop_blocks(lambda n, b: n in drop)

    def _drop_blocks(self, which):
        """Unmap here the blocks ``which(name, entry)`` picks (those still viewed by surfaces stay mapped through
        them), and have the workers unmap them at their next write."""
        for name, b in list(self._blocks.items()):
            if which(name, b):
                del self._blocks[name]
                self._forget.append(name)
                if b[2]:
                    with contextlib.suppress(BufferError):
                        b[0].close()

    def _sweep(self, calls, names):
        """After a query: every call answered or failed, then every block name made unlinked (a query that
        failed midway leaves blocks that no one else would unlink)."""
        for row in calls:
            for call in row:
                with contextlib.suppress(Exception):  # a lost worker's call: its error is the query's already
                    call.result(timeout=SWEEP_TIMEOUT_S)
        for row in names:
            for name in row:
                _unlink_quietly(name)

    def _run_query(self, values, normals):
        """The stitched surfaces, or ``_Lost`` naming a partition whose actor could not answer."""
        if self.stitch_on == "client":
            return self._run_on_client(values, normals)
        distributed = require_distributed()
        leaves, roots = self._submit_query(values, normals)
        distributed.wait(roots)
        if all(r.status == "finished" for r in roots):
            out = self.client.gather(roots)
            self._sent = sum(o["sent"] for o in out)
            return ([_widen(s) for o in out for s in o["surfaces"]], sum(o["moved"] for o in out),
                    sum(o["made"] for o in out))
        # a leaf failed: our own error as it is, anything else (a worker or actor lost) as a lost partition
        for lv in leaves:
            for i, f in enumerate(lv):
                if f.status == "error":
                    e = f.exception()
                    if isinstance(e, (PartitionError, ValueError)):
                        raise e
                    raise _Lost(i, e)
                if f.status != "finished":
                    raise _Lost(i, RuntimeError(f"its task ended as {f.status!r}"))
        for r in roots:
            if r.status == "error":
                raise r.exception()
        raise PartitionError("a query's merges did not finish; no surface returned")

    def extract_many(self, values, *, normals="mean"):
        """The stitched surfaces of ``values`` (one task per partition and chunk of values, merged on the workers)."""
        values = [check_value(v) for v in values]
        _check_normals(normals)
        t0 = time.perf_counter()
        self.blocks_last = []
        for attempt in range(RETRIES + 1):
            try:
                surfaces, moved, made = self._run_query(values, normals)
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
        self.bytes_workers_last = int(moved)
        self.bytes_pieces_last = int(made)
        self.bytes_last = made if self.stitch_on == "client" else self._sent
        return surfaces

    def extract(self, value, *, normals="mean"):
        """The stitched surface ``S = value``."""
        return self.extract_many([value], normals=normals)[0]

    def close(self):
        """Release the actors (the partitions on the workers, and their mappings of the blocks)."""
        self._drop_blocks(lambda n, b: True)
        self._forget = []
        for ch in self.channels:
            if ch is not None:
                ch.close()
        self.channels = [None] * len(self.pieces)
        for f in self._futures:
            if f is not None:
                f.release()
        self._futures = [None] * len(self.pieces)
        self.actors = [None] * len(self.pieces)



def _as_dask_threads(fn):
    """Run ``fn`` (a call on a worker) with numba's parallel regions limited to the worker's thread count.

    ``numba.set_num_threads`` holds for the calling thread, so every entry
    point that runs on a worker (tasks, actor methods) sets it; outside a
    Dask worker it does nothing.
    """

    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            from distributed import get_worker

            n = get_worker().state.nthreads
        except (ImportError, ValueError, AttributeError):
            n = None
        if n is not None:
            import numba

            numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
        return fn(*args, **kwargs)

    return call


class SharedMemoryPartition(PreparedPartition):
    """A partition on a worker of this machine: it writes its rows of the stitched surfaces into shared memory.

    Two calls per chunk of values (:meth:`DaskPartitionedMethod._run_direct`):
    :meth:`find_shared` extracts the surfaces, keeps them and answers their
    counts and seam vertices; :meth:`write_shared` writes this partition's
    rows of every stitched array into the block the client made for the
    chunk, at the rows the client laid out, and forgets the surfaces. The
    stitched arrays are written once, by the workers, into memory the
    client's surfaces keep: pieces copied into blocks and merged by the
    client into fresh arrays cost the client a copy and the first touch of
    every output page (10M, 20 values: 0.43 s of its stitch, against the
    single volume's ~1.5 s of CPU for the whole sweep;
    ``benchmarks/results/partitioned_overhead.md``).

    Ownership: the client makes and names a block (one per chunk), each
    worker maps it at its first write and keeps it mapped, and the client
    unlinks the name once every partition wrote (or, a query that failed,
    once its calls have all answered or failed). Once the surfaces of a
    block are gone the client may hand it to a later chunk (written again
    in place); when it gives a block up, the workers unmap it at their next
    write (or when the partition goes), and the memory goes with the last
    mapping.
    """

    @_as_dask_threads
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._pending = {}  # (query, chunk) -> the surfaces found, waiting for their write
        self._maps = {}  # block name -> its mapping here, kept until the client gives the block up

    @_as_dask_threads
    def set_layout(self, *args, **kwargs):
        return super().set_layout(*args, **kwargs)

    @_as_dask_threads
    def extract_many(self, *args, **kwargs):
        return super().extract_many(*args, **kwargs)

    @_as_dask_threads
    def open_channel(self, authkey):
        """Listen for the client's connection (a Unix socket) and answer its calls on a thread of their own.

        The client's :class:`_Channel` sends ``(method name, args)``; the
        thread calls the method (one call at a time, in order, as an actor
        does; ``self._lock`` keeps them apart from Dask's calls) with numba
        on this worker's threads, and answers ``(True, result)`` or
        ``(False, exception)``. It ends when the client closes the
        connection. Returns the socket's address.
        """
        import numba
        from multiprocessing.connection import Listener

        listener = Listener(family="AF_UNIX", authkey=bytes(authkey))
        threading.Thread(target=self._serve, args=(listener, numba.get_num_threads()), daemon=True,
                         name=f"polygen-partition-{self.index}").start()
        return listener.address

    def _serve(self, listener, n_threads):
        import numba

        numba.set_num_threads(n_threads)
        try:
            conn = listener.accept()
        except Exception:  # noqa: BLE001  the client went before connecting (or with the wrong key)
            return
        finally:
            listener.close()
        with conn:
            while True:
                try:
                    name, args = conn.recv()
                except (EOFError, OSError):  # the client closed its end (or is gone)
                    return
                if name not in ("find_shared", "write_shared"):
                    answer = (False, PartitionError(f"no such partition call {name!r}"))
                else:
                    try:
                        answer = (True, getattr(self, name)(*args))
                    except Exception as e:  # noqa: BLE001  sent to the client, raised there
                        answer = (False, e)
                try:
                    conn.send(answer)
                except (EOFError, OSError):
                    return
                except Exception as e:  # noqa: BLE001  an exception that does not pickle: its words do
                    conn.send((False, PartitionError(f"{type(answer[1]).__name__}: {answer[1]}")))
                    del e

    @_as_dask_threads
    def find_shared(self, values, normals, tag):
        """Extract ``values`` and keep the surfaces under ``tag``; answer counts, seam vertices and counters."""
        t0, c0 = time.perf_counter(), time.thread_time()
        with self._lock:
            for old in [t for t in self._pending if t[0] != tag[0]]:  # a query that failed before its writes
                del self._pending[old]
            isos, found = [], []
            for v in values:
                iso, counters = self.surface(v)
                marks = self.marks(iso)
                isos.append((iso, marks))
                found.append(counters | {"n": iso.vertices.shape[0], "m": iso.triangles.shape[0],
                                         "seam": marks["seam"], "seam_keys": marks["seam_keys"]})
            self._pending[tag] = isos
        c1 = time.thread_time()
        return {"found": found, "timing": {"kind": "find", "start": t0, "end": time.perf_counter(),
                                           "cpu_s": c1 - c0, "surface_cpu_s": c1 - c0, "piece_cpu_s": 0.0}}

    @_as_dask_threads
    def write_shared(self, tag, name, layouts, normals, forget=()):
        """Write this partition's rows of the surfaces kept under ``tag`` into the shared-memory block ``name``.

        ``layouts``: per value, ``n_vertices``, ``n_triangles`` (the stitched
        surface's), ``offset`` (its arrays' first byte in the block) and this
        partition's ``plan`` (:func:`~polygen.volume.partitioned.rows_layout`).
        The block stays mapped here for its next chunk; ``forget``: blocks
        the client gave up, unmapped first.
        """
        t0, c0 = time.perf_counter(), time.thread_time()
        with self._lock:
            for old in forget:
                block = self._maps.pop(old, None)
                if block is not None:
                    with contextlib.suppress(BufferError):
                        block.close()
            isos = self._pending.pop(tag)
            block = self._maps.get(name)
            if block is None:
                block = self._maps[name] = _open_block(name)
            written = []
            for (iso, marks), lay in zip(isos, layouts):
                out, _ = rows_arrays(lay, normals, buf=block, offset=lay["offset"])
                written.append(self.write_rows(iso, normals, lay["plan"], out, marks))
                out = None
        c1 = time.thread_time()
        return {"written": written, "timing": {"kind": "write", "start": t0, "end": time.perf_counter(),
                                               "cpu_s": c1 - c0, "surface_cpu_s": 0.0, "piece_cpu_s": c1 - c0}}


def _new_block(name, size):
    """A new POSIX shared-memory block ``name`` of ``size`` bytes, mapped here (pages untouched)."""
    import _posixshmem

    fd = _posixshmem.shm_open("/" + name, os.O_CREAT | os.O_EXCL | os.O_RDWR, 0o600)
    try:
        os.ftruncate(fd, size)
        return mmap.mmap(fd, size)
    finally:
        os.close(fd)


def _open_block(name):
    """The shared-memory block ``name``, mapped here."""
    import _posixshmem

    try:
        fd = _posixshmem.shm_open("/" + name, os.O_RDWR, 0o600)
    except FileNotFoundError as e:
        raise PartitionError(f"shared-memory block {name!r} is gone (its query was given up)") from e
    try:
        return mmap.mmap(fd, os.fstat(fd).st_size)
    finally:
        os.close(fd)


def _chunked(values, size=None):
    """``values`` in chunks of ``size``; by default ``CHUNKS`` chunks, the last one cut in halves down to one
    value (4 -> 2, 1, 1): the client's stitch of the last chunk waits for nothing else, so it is kept short."""
    if size:
        return [values[i:i + size] for i in range(0, len(values), size)]
    size = max(1, -(-len(values) // CHUNKS))
    chunks = [values[i:i + size] for i in range(0, len(values), size)]
    if chunks:
        last, tail = chunks.pop(), []
        while last:
            h = -(-len(last) // 2) if len(last) > 2 else 1
            tail.append(last[:h])
            last = last[h:]
        chunks += tail
    return chunks


def _direct_chunks(values, size=None):
    """``values`` in chunks of ``size`` (default ``DIRECT_CHUNK_VALUES``), of equal size but the last."""
    size = size or DIRECT_CHUNK_VALUES
    n = max(1, -(-len(values) // size))  # as few chunks as that size allows, as even as can be
    return _chunked(values, max(1, -(-len(values) // n)))


def _unlink_quietly(name):
    """Unlink the shared-memory block ``name`` if it still exists (a query that failed midway).

    By name, without mapping it: a worker killed between creating a block and
    sizing it leaves an empty one, which cannot be mapped.
    """
    try:
        import _posixshmem
    except ImportError:  # no POSIX shared memory: no block was made
        return
    with contextlib.suppress(OSError):  # FileNotFoundError: unlinked already (the usual case)
        _posixshmem.shm_unlink("/" + name)


class _Channel:
    """The client's end of a connection to one partition on a worker of this machine (``open_channel``).

    ``call(name, *args)`` sends at once and returns a reply whose
    ``result(timeout=None)`` waits for the answer: the calls are answered in
    the order they were sent, so replies that come before the one waited
    for are kept. A connection that breaks (the worker is gone) raises
    ``ConnectionError`` for every call not answered.
    """

    def __init__(self, address, authkey, index):
        from multiprocessing.connection import Client

        self.index = index
        self.conn = Client(address, family="AF_UNIX", authkey=bytes(authkey))
        self._sent = 0
        self._received = 0
        self._answers = {}
        self._broken = None

    def call(self, name, *args):
        if self._broken is not None:
            raise self._broken
        try:
            self.conn.send((name, args))
        except (EOFError, OSError) as e:
            self._broken = ConnectionError(f"partition {self.index}: its connection broke ({e!r})")
            raise self._broken from e
        self._sent += 1
        return _Reply(self, self._sent - 1)

    def _wait(self, seq, timeout):
        while seq not in self._answers:
            if self._broken is not None:
                raise self._broken
            try:
                if timeout is not None and not self.conn.poll(timeout):
                    raise TimeoutError(f"partition {self.index}: no answer in {timeout} s")
                answer = self.conn.recv()
            except (EOFError, OSError) as e:
                self._broken = ConnectionError(f"partition {self.index}: its connection broke ({e!r})")
                raise self._broken from e
            self._answers[self._received] = answer
            self._received += 1
        ok, value = self._answers.pop(seq)
        if not ok:
            raise value
        return value

    def close(self):
        with contextlib.suppress(OSError):
            self.conn.close()
        self._broken = self._broken or ConnectionError(f"partition {self.index}: its connection was closed")


class _Reply:
    def __init__(self, channel, seq):
        self.channel, self.seq = channel, seq

    def result(self, timeout=None):
        return self.channel._wait(self.seq, timeout)


class _Lost(Exception):
    def __init__(self, index, cause):
        super().__init__(f"partition {index}: {cause!r}")
        self.index, self.cause = index, cause


def _nbytes(piece):
    """Bytes of a piece's arrays (its fallback rows included)."""
    fb = piece.get("fallback")
    return int(sum(v.nbytes for v in piece.values() if isinstance(v, np.ndarray))
               + (fb[0].nbytes + fb[1].nbytes if fb is not None else 0))


def _surface_nbytes(s):
    return int(sum(a.nbytes for a in (s.vertices, s.normals, s.triangles, s.vertex_keys, s.triangle_cells)
                   if a is not None))


def _here():
    from distributed import get_worker

    return get_worker().address


@_as_dask_threads
def _leaf(actor, key, values, normals):
    """On a worker: the partition's pieces of ``values``.

    The partition lives on this worker (the task is placed beside it): it is
    called here, in this task's thread -- an actor call from a task goes
    through the worker's RPC and the actor's own thread, and two threads of
    one process then take turns at the GIL with the merges (measured on
    data 4: a merge's wall clock 20x its CPU time). If the partition is
    elsewhere (the task ran on another worker), it is asked through its
    actor, and its pieces count as moved.
    """
    from distributed import get_worker

    w = get_worker()
    here = w.address
    part = w.state.actors.get(key)
    if isinstance(part, PreparedPartition):
        pieces, moved = part.extract_many(values, normals), False
    else:
        pieces, moved = actor.extract_many(values, normals).result(), True
    made = sum(_nbytes(p) for p in pieces)
    return {"where": here, "moved": made if moved else 0, "made": made, "pieces": pieces}


def _moved_in(*nodes):
    here = _here()
    return here, sum(n["moved"] + (sum(_nbytes(p) for p in n["pieces"]) if n["where"] != here else 0)
                     for n in nodes)


@_as_dask_threads
def _merge(n_ids, left, right):
    """On a worker: two neighbouring nodes of the tree merged, value by value."""
    here, moved = _moved_in(left, right)
    return {"where": here, "moved": moved, "made": left["made"] + right["made"],
            "pieces": [_narrow(merge([a, b], n_ids=n_ids)) for a, b in zip(left["pieces"], right["pieces"])]}


def _narrow(piece):
    """A merged piece with int32 triangles and cell ids where they fit (for its way to the next merge)."""
    tc = piece["triangle_cells"]
    if piece["keys"].shape[0] < 2**31 and (tc.size == 0 or tc.max() < 2**31):
        piece = piece | {"triangles": piece["triangles"].astype(np.int32), "triangle_cells": tc.astype(np.int32)}
    return piece


@_as_dask_threads
def _finish(values, n_ids, normals, root):
    """On a worker: the root's pieces made surfaces (normals on the whole surface).

    Triangles and cell ids travel to the client as int32 when they fit
    (:func:`_widen` restores int64 there): 16 of ~60 bytes per triangle.
    """
    here, moved = _moved_in(root)
    out = []
    for v, p in zip(values, root["pieces"]):
        s = finish(v, p, n_ids=n_ids, normals=normals)
        if s.n_vertices < 2**31 and (s.triangle_cells.size == 0 or s.triangle_cells.max() < 2**31):
            s = dataclasses.replace(s, triangles=s.triangles.astype(np.int32),
                                    triangle_cells=s.triangle_cells.astype(np.int32))
        out.append(s)
    return {"moved": moved, "made": root["made"], "sent": sum(_surface_nbytes(s) for s in out), "surfaces": out}


def _widen(s):
    """A surface from :func:`_finish` with int64 triangles and cell ids again."""
    return dataclasses.replace(s, triangles=s.triangles.astype(np.int64),
                               triangle_cells=s.triangle_cells.astype(np.int64))


def _takes_n_workers(client):
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters
