"""BLAS threads for small linear algebra.

The learning loops of greyml (an ANFIS epoch, a swarm generation, a
Levenberg–Marquardt step) multiply matrices of a few thousand entries, many
times. A multi-threaded BLAS gains nothing on such products and, when the
cores are busy (a cross-validation or a grid search running other fits, a
Dask worker), its threads spin and wait: measured on this project's 2-core CI
machine under load, 300 ANFIS epochs took 15-22 s with two OpenBLAS threads
and 0.75 s with one. Fits whose products are small therefore run with one
BLAS thread; large ones (hundreds of rules) keep the library's setting.
"""

from __future__ import annotations

from contextlib import nullcontext

from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads_for"]

#: Floating-point operations per product below which one thread is used.
SMALL_WORK = 5e7

_controller = None


def _get_controller():
    # scanning the loaded libraries costs ~2 ms: do it once, not per predict
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller


def blas_threads_for(flops: float):
    """Context manager: one BLAS thread if a product costs fewer than
    :data:`SMALL_WORK` flops, else leave the thread count alone."""
    if flops < SMALL_WORK:
        return _get_controller().limit(limits=1, user_api="blas")
    return nullcontext()
