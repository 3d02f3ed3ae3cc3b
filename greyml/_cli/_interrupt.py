"""Ctrl-C and SIGTERM while a ``greyml`` command runs.

Python stops at Ctrl-C (SIGINT) by raising :class:`KeyboardInterrupt`, so the
``finally`` blocks that remove a half-written file run; SIGTERM (``kill``, a
service manager, a CI runner's timeout) would end the process at once and
leave them. :func:`interrupts` makes both raise :class:`Interrupted` (a
:class:`KeyboardInterrupt`) once, so both clean up alike; a repeated signal
meanwhile is noted, not raised, so that the cleanup runs to its end (Ctrl-\\
still ends the process at once).

Python runs a signal's handler between any two steps of the program, also
inside a finaliser (``__del__``, a weak reference's callback), where an
exception is printed as "Exception ignored in ..." and dropped. The
exception is then caught on its way to :data:`sys.unraisablehook` and the
signal raised again a moment later, from another thread, so that it stops
the command once the finaliser has returned.
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import signal
import sys
import threading
import time


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM received while a ``greyml`` command ran.

    Parameters
    ----------
    signum : int
        The signal's number.
    """

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


class _Signals:
    """The first signal received (``first``), and whether one still raises (``armed``)."""

    #: Seconds before a signal dropped in a finaliser is raised again.
    AGAIN_S = 0.01

    def __init__(self):
        self.first = None
        self.armed = True
        self.active = True  # False once the handlers are put back
        self.lock = threading.Lock()

    def handler(self, signum, frame):
        if self.first is None:
            self.first = signum
        if self.armed:
            self.armed = False  # one exception: a second signal cannot cut the cleanup short
            raise Interrupted(signum)

    def disarm(self):
        """From now on a signal is only noted (the command has finished)."""
        self.armed = False

    def unraisable(self, unraisable, *, chained):
        """:data:`sys.unraisablehook`: an :class:`Interrupted` dropped in a finaliser
        is raised again; anything else goes on to ``chained``, the hook before.

        The signal is raised again from another thread after :attr:`AGAIN_S`:
        raised here, it would be dropped again, as the hook runs inside the
        finaliser. Dropped again anyway (the main thread in another
        finaliser), it comes back here and is tried once more.
        """
        exc = unraisable.exc_value
        if not isinstance(exc, Interrupted):
            chained(unraisable)
            return
        self.armed = True
        threading.Thread(target=self._again, args=(exc.signum,), daemon=True).start()

    def _again(self, signum):
        time.sleep(self.AGAIN_S)
        with self.lock:
            if not (self.active and self.armed):
                return
            if hasattr(signal, "pthread_kill"):  # also wakes a main thread that waits
                signal.pthread_kill(threading.main_thread().ident, signum)
            else:
                _thread.interrupt_main(signum)

    def close(self):
        """The handlers are put back: nothing is raised again from now on."""
        with self.lock:
            self.active = False


#: The signals of the command that runs (:func:`interrupts`), if any.
_running = None


@contextlib.contextmanager
def interrupts():
    """SIGINT and SIGTERM raise :class:`Interrupted` once, meanwhile.

    Yields the :class:`_Signals` that notes them. The previous handlers are
    restored at the end. A signal that is ignored (``SIG_IGN``, as for a
    command started in the background) stays ignored, and one handled outside
    Python is left alone; outside the main thread, where Python cannot handle
    signals, nothing changes.
    """
    global _running
    signals = _Signals()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(signum)
            # None: a handler installed outside Python, which could not be put back
            if handler is not None and handler is not signal.SIG_IGN:
                previous[signum] = handler
                signal.signal(signum, signals.handler)
    outer, _running = _running, signals
    hook = sys.unraisablehook
    if previous:
        sys.unraisablehook = functools.partial(signals.unraisable, chained=hook)
    try:
        yield signals
    finally:
        signals.close()
        sys.unraisablehook = hook
        _running = outer
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def deferred():
    """A signal received meanwhile raises :class:`Interrupted` at the end, not inside.

    For a few quick steps that must not be cut in two, such as moving a set of
    finished files into place: they all happen, then the command stops.
    Outside :func:`interrupts` (or once a signal has been raised), nothing changes.
    """
    signals = _running
    if signals is None or not signals.armed:
        yield
        return
    signals.armed = False
    try:
        yield
    finally:
        if signals.first is None:
            signals.armed = True
    if signals.first is not None:
        raise Interrupted(signals.first)
