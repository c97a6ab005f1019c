"""The edge-centred records moved to transparent huge pages after the build (issue 20).

``polygen._jit.collapse_to_huge_pages`` asks Linux (``MADV_COLLAPSE``, 6.1+) to back an
array by 2 MiB pages; ``EdgeCentredTable`` does it for its records and cell lists in a
background thread while queries may already run. Oracles: the kernel's own account of the
mapping (``/proc/self/smaps``), the array's contents before and after, and the surfaces of a
builder without huge pages.
"""

import mmap
import os
import threading

import numpy as np
import pytest

from polygen import _jit
from polygen.volume import datasets, methods
from polygen.volume.edge_centred import EdgeCentredTable

from _surfaces import iso_values  # noqa: E402


def _collapse_supported():
    if os.uname().sysname != "Linux":
        return False
    try:
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
            mode = f.read()
    except OSError:
        return False
    major, minor = (int(x) for x in os.uname().release.split(".")[:2])
    return "[never]" not in mode and (major, minor) >= (6, 1)


def _anon_huge_kb(address):
    """``AnonHugePages`` of the mapping that holds ``address`` (kB), from /proc/self/smaps."""
    inside = False
    with open("/proc/self/smaps") as f:
        for line in f:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                lo, hi = (int(x, 16) for x in head.split("-"))
                inside = lo <= address < hi
            elif inside and head == "AnonHugePages:":
                return int(line.split()[1])
    return 0


def test_small_or_strided_arrays_are_left_alone():
    assert _jit.collapse_to_huge_pages(np.zeros(1000)) == 0
    big = _jit.empty((1 << 21,), np.int32)
    assert _jit.collapse_to_huge_pages(big[::2]) == 0  # not contiguous


@pytest.mark.skipif(not _collapse_supported(), reason="needs Linux 6.1+ with transparent huge pages allowed")
def test_collapse_backs_the_interior_by_huge_pages_and_keeps_the_contents():
    # a mapping of its own (anonymous mmap, 4 KiB pages, no advice), so that the kernel's account of
    # that mapping counts this array alone: a heap block may reuse memory that is huge already
    size = 20 << 20
    mm = mmap.mmap(-1, size, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)  # private: not shared memory
    a = np.frombuffer(mm, dtype=np.int32)
    a[...] = np.arange(a.size, dtype=np.int32) * 7
    got = _jit.collapse_to_huge_pages(a)
    # the 2 MiB-aligned interior: all of it but at most one page at each end
    assert got % _jit.HUGE_PAGE_BYTES == 0 and a.nbytes - 2 * _jit.HUGE_PAGE_BYTES <= got <= a.nbytes
    assert _anon_huge_kb(a.ctypes.data + a.nbytes // 2) >= got // 1024
    assert np.array_equal(a, np.arange(a.size, dtype=np.int32) * 7)


@pytest.fixture(scope="module")
def vol():
    return datasets.load("data3")  # 345k tetrahedra: 21 MB of records


def _surface(iso):
    return iso.triangles.copy(), iso.vertex_keys.copy(), iso.vertices.copy(), iso.normals.copy()


def test_queries_during_and_after_the_collapse_equal_those_on_small_pages(vol, monkeypatch):
    values = iso_values(vol.scalars("fem"), 6)
    monkeypatch.setattr(EdgeCentredTable, "HUGE_PAGES", False)
    plain = methods.get("edge-centred-table")(vol, field="fem")
    plain.builder.threads = 1
    assert plain.builder._settling is None and plain.builder.settle() == 0
    want = [_surface(plain.extract(v)) for v in values]
    monkeypatch.setattr(EdgeCentredTable, "HUGE_PAGES", True)
    for _ in range(2):
        huge = methods.get("edge-centred-table")(vol, field="fem")
        huge.builder.threads = 1
        got = [_surface(huge.extract(v)) for v in values]  # the background thread may be collapsing now
        collapsed = huge.builder.settle()
        assert not huge.builder._settling.is_alive()
        got += [_surface(huge.extract(v)) for v in values]
        for a, b in zip(want + want, got):
            for x, y in zip(a, b):
                assert np.array_equal(x, y)
        if _collapse_supported():
            # the kernel may refuse an array (no memory to compact: it keeps its 4 KiB pages); each one it
            # took is backed by huge pages by its own account
            assert collapsed > 0
            big = [a for a in (huge.builder.rec, huge.builder.ec) if a is not None and a.nbytes >= _jit.HUGE_PAGE_BYTES]
            for a, n in zip(big, huge.builder._settling.collapsed_each, strict=True):
                assert n == 0 or _anon_huge_kb(a.ctypes.data + a.nbytes // 2) > 0
        else:
            assert collapsed == 0


def test_settle_is_safe_from_several_threads(vol):
    b = EdgeCentredTable(vol, "fem", threads=1)
    out = []
    threads = [threading.Thread(target=lambda: out.append(b.settle())) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(out)) == 1 and out[0] == b.settle()
