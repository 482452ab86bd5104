"""One BLAS thread while the batched solver works on its many tiny systems.

The solver's matrix products are tall and thin (thousands of steps times a few bodies, complex)
and its factorisations are 6 x 6: OpenBLAS splits such products over its threads, and on a
machine whose cores are busy with other work the threads wait for each other (figures in
docs/performance.md, *Speed as installed*).

:func:`single_blas_thread` limits every BLAS library loaded in the process (numpy's and scipy's
OpenBLAS are separate libraries) to one thread for the duration of a ``with`` block and restores
the previous limits afterwards. The libraries are found once per process (threadpoolctl scans
the loaded shared objects); a limit set by the caller's own ``threadpool_limits``
is respected, since a smaller limit is never raised.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Iterator

__all__ = ["single_blas_thread"]

logger = logging.getLogger(__name__)

_lock = threading.Lock()
_controller = None


def _blas_controller():
    """Find the process's BLAS libraries (on the first call; later calls reuse them)."""
    global _controller
    with _lock:
        if _controller is None:
            import numpy  # noqa: F401 (its BLAS must be loaded before the scan)
            import scipy.linalg  # noqa: F401
            from threadpoolctl import ThreadpoolController

            _controller = ThreadpoolController().select(user_api="blas")
            logger.debug("BLAS libraries: %s", [(lib.internal_api, lib.filepath, lib.num_threads)
                                               for lib in _controller.lib_controllers])
        return _controller


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Run the ``with`` block with one BLAS thread, then restore the previous thread counts."""
    controller = _blas_controller()
    if all(lib.num_threads <= 1 for lib in controller.lib_controllers):
        yield
        return
    with controller.limit(limits=1):
        yield
