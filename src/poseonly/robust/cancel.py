"""Cancelling searches that run in worker threads.

Python runs signal handlers in its main thread only, so a search there ends within 64 draws of Ctrl-C
(``check_signals``), while one in a worker thread cannot see it: a batch on ``backend="threads"``
waited for the searches running when Ctrl-C came (7.7 s in a review's run) or when its caller stopped
iterating. A batch gives each worker thread a :class:`poseonly._core.CancelFlag` (:func:`cancellable`)
and sets it when it stops; the searches started under it (:func:`current`, read by
:func:`poseonly.robust.ransac.ransac_relpose`) read the flag every 64 draws without the GIL and end
with :class:`SearchCancelled`. A flag that is never set changes no result.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from .. import _core

__all__ = ["CancelFlag", "SearchCancelled", "cancellable", "current"]

CancelFlag = _core.CancelFlag
SearchCancelled = _core.SearchCancelled  # an Exception, not a ValueError: a batch does not take it for bad input

_local = threading.local()


def current() -> _core.CancelFlag | None:
    """The flag the searches of this thread read (None outside :func:`cancellable`)."""
    flag: _core.CancelFlag | None = getattr(_local, "flag", None)
    return flag


@contextlib.contextmanager
def cancellable(flag: _core.CancelFlag) -> Iterator[None]:
    """Searches started in this thread inside the block end with :class:`SearchCancelled` once ``flag``
    is set."""
    previous = current()
    _local.flag = flag
    try:
        yield
    finally:
        _local.flag = previous
