"""Memory estimates checked before a large allocation: one clear error instead of swapping until killed.

A request whose arrays cannot fit in this machine's physical memory (``os.sysconf``: page size times
physical pages) is refused before anything is allocated, by the wrapper that would allocate it, with
an error naming the parameter, the estimate and the limit. The estimates are lower
bounds of what the request holds at once (its largest arrays), so a refusal is never a false alarm.
"""

import os

__all__ = ["physical_memory", "check_fits", "format_bytes"]


def physical_memory():
    """Bytes of physical memory on this machine (``SC_PAGE_SIZE * SC_PHYS_PAGES``; None where unknown)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return None


def format_bytes(n):
    n = float(n)
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} EiB"  # pragma: no cover


def check_fits(nbytes, what, error):
    """Raise ``error(message)`` when ``nbytes`` (an estimate) exceeds physical memory.

    ``what`` names the parameter and its value (``"element_levels=13"``); the message gives the
    estimate and the limit.
    """
    limit = physical_memory()
    if limit is not None and nbytes > limit:
        raise error(f"{what} needs about {format_bytes(nbytes)} of memory, more than this machine's "
                    f"{format_bytes(limit)}")
