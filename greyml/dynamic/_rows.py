"""Training rows given in pieces: one pass that checks them and keeps what a fit
needs of every row, and the passes after it that read them again.

A dynamic fit reads its rows more than once (their Grams, then the held-out
predictions its intervals are calibrated on), but never needs them all at
once: what it keeps of every row is its time, target and weight (24 bytes a
row, whatever the number of inputs), and of every test its first row. The
inputs are read again, piece by piece, at each pass. Rows held in memory are
one piece; a list of files, many: the fit is the same either way, because
every statistic is computed the same way over the same rows in the same order.

The pieces are ``(X, y)`` or ``(X, y, sample_weight)``, as ``fit`` takes
them, in the order of the rows: a test may run on from one piece into the
next (the same label), but may not come back after another test.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pandas as pd

from greyml._sequences import TEST_LEVEL, Segment, segment_label
from greyml._validation import check_magnitudes, column_names, validate_sequences
from greyml.dynamic import _gram
from greyml.dynamic._time import _times

__all__ = ["MAX_CHANGES", "Rows", "read_rows"]

#: A sensor's resolution is estimated on its first this many changes between
#: rows (in the order of the tests): the median's relative standard error is
#: then below 0.4 %, and a year of rows costs no more than a day's.
MAX_CHANGES = 1 << 17


@dataclass
class Rows:
    """What a fit keeps of its training rows.

    Attributes
    ----------
    names : list of str
        The columns of ``X``.
    t, y, w : ndarray of shape (n_samples,)
        Each row's time (s), target and weight.
    clocked : bool
        Whether the times come from a ``time_s`` level.
    labelled : bool
        Whether the rows carry test labels (a ``test`` level).
    segments : list of Segment
        The tests, in the rows' numbers.
    first_rows : ndarray of shape (n_tests, n_features)
        Each test's first row of ``X``.
    peaks : ndarray of shape (n_features,)
        The largest ``|x|`` of each column.
    changes : ndarray of shape (<= MAX_CHANGES, n_features)
        The first changes between successive rows of a test, in order.
    X : ndarray or None
        The inputs when they are held in memory (one piece).
    """

    names: list
    t: np.ndarray
    clocked: bool
    labelled: bool
    y: np.ndarray
    w: np.ndarray
    segments: list
    first_rows: np.ndarray
    peaks: np.ndarray
    changes: np.ndarray
    X: np.ndarray | None
    source: object = None
    sizes: tuple = ()
    owner: object = None

    def chunks(self) -> Iterator[tuple[int, np.ndarray]]:
        """``(r0, x)``: the inputs of rows ``r0 : r0 + len(x)``, every row in order,
        in pieces of :data:`~greyml.dynamic._gram.CHUNK_ROWS` rows (the last shorter),
        read again from the pieces given if they are not held in memory (each
        checked to be what the first pass read)."""
        if self.X is not None:
            for r0 in range(0, self.X.shape[0], _gram.CHUNK_ROWS):
                yield r0, self.X[r0 : r0 + _gram.CHUNK_ROWS]
            return
        # the pieces cut again where rows held in memory are cut: every sum then
        # adds the same rows in the same order, whatever the pieces were
        buffer, r0 = [], 0
        for start, x in self._read_again():
            buffer.append(x)
            held = start + x.shape[0] - r0
            while held >= _gram.CHUNK_ROWS or (held and start + x.shape[0] == self.t.size):
                rows = np.concatenate(buffer) if len(buffer) > 1 else buffer[0]
                take = min(_gram.CHUNK_ROWS, held)
                yield r0, rows[:take]
                buffer, r0, held = [rows[take:]], r0 + take, held - take

    def _read_again(self):
        """``(r0, x)`` of every piece as given, checked to be what the first pass read,
        the next piece read and checked in a thread while this one is used (reading
        and parsing a file overlap the fit's arithmetic)."""
        ahead = queue.Queue(maxsize=1)
        stop = threading.Event()

        def put(item):
            while not stop.is_set():
                try:
                    ahead.put(item, timeout=0.05)
                    return True
                except queue.Full:
                    continue
            return False

        def read():
            try:
                for piece in self._read_pieces():
                    if not put(("piece", piece)):
                        return
                put(("done", None))
            except BaseException as error:  # handed to the reader, raised there
                put(("error", error))

        worker = threading.Thread(target=read, name="greyml-read-ahead", daemon=True)
        worker.start()
        try:
            while True:
                kind, item = ahead.get()
                if kind == "done":
                    return
                if kind == "error":
                    raise item
                yield item
        finally:
            stop.set()
            worker.join()

    def _read_pieces(self):
        """``(r0, x)`` of every piece as given, checked to be what the first pass read."""
        r0 = 0
        pieces = iter(self.source)
        for j, size in enumerate(self.sizes):
            item = next(pieces, None)
            name = type(self.owner).__name__
            if item is None:
                raise ValueError(
                    f"{name}: the pieces of the training data ran out at piece {j} when "
                    "read again; give a sequence (a list, or greyml.io.TestFiles) that "
                    "gives the same pieces every time it is iterated."
                )
            X, y, _ = _unpack(item, name)
            Xa, _, segs = validate_sequences(self.owner, X, y, reset=False)
            same = Xa.shape[0] == size
            if same and self.clocked:
                t, _ = _times(X, segs, name, None)
                same = np.array_equal(t, self.t[r0 : r0 + size])
            if not same:
                raise ValueError(
                    f"{name}: piece {j} of the training data is not what was read the first "
                    f"time ({Xa.shape[0]} rows, {size} before, or other times); the data "
                    "changed during the fit."
                )
            yield r0, Xa
            r0 += size


def _unpack(item, name):
    """``(X, y, sample_weight)`` of one piece."""
    if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
        raise ValueError(
            f"{name}: each piece of the training data must be (X, y) or "
            f"(X, y, sample_weight); got {type(item).__name__}."
        )
    return (*item, None) if len(item) == 2 else tuple(item)


def _peaks(x):
    """The largest ``|x|`` of each column, a block of rows at a time (no copy of ``x``)."""
    out = np.zeros(x.shape[1])
    for r0 in range(0, x.shape[0], _gram.CHUNK_ROWS):
        block = x[r0 : r0 + _gram.CHUNK_ROWS]
        out = np.maximum(out, np.maximum(block.max(axis=0), -block.min(axis=0)))
    return out


def read_rows(estimator, pieces, *, weights, default_step, keep):
    """The :class:`Rows` of ``pieces`` (an iterable of ``(X, y[, sample_weight])``),
    checked as ``fit`` checks one ``X``: columns, values, magnitudes, weights,
    test labels and times.

    ``weights(sample_weight, n, segments)`` checks one piece's weights;
    ``default_step`` is the seconds per row without a ``time_s`` level (None
    refuses such rows); with ``keep`` (one piece only) the inputs are kept in
    memory, otherwise ``pieces`` is read again at every pass.
    """
    name = type(estimator).__name__
    ts, ys, ws, firsts, sizes, changes = [], [], [], [], [], []
    segments, seen = [], set()
    peaks, last_row, last_t, n_changes = None, None, None, 0
    held, clocked, labelled, names = None, None, None, None
    n = 0
    for j, item in enumerate(pieces):
        X, y, sample_weight = _unpack(item, name)
        try:
            Xa, ya, segs = validate_sequences(estimator, X, y, reset=j == 0)
            if j == 0:
                names = column_names(estimator, Xa.shape[1])
                index = X.index if isinstance(X, (pd.DataFrame, pd.Series)) else None
                labelled = index is not None and TEST_LEVEL in (index.names or [])
            else:
                check_magnitudes(estimator, Xa, names, segs)
                check_magnitudes(estimator, ya[:, None], ["the target y"], segs)
            w = weights(sample_weight, Xa.shape[0], segs)
        except ValueError as error:
            source = getattr(X, "attrs", {}).get("greyml_source")
            if source is not None:
                where = f"in {source}"
            elif j == 0:
                raise  # the first piece's rows are counted as the data's
            else:
                where = f"rows counted from row {n:,}, the first of piece {j} of the data"
            raise ValueError(f"{str(error).rstrip('.')} ({where}).") from None
        t, clocked_here = _times(X, segs, name, default_step)
        clocked = clocked_here if clocked is None else clocked and clocked_here
        on = bool(segments) and segs[0].label == segments[-1].label
        if on:  # the last test runs on into this piece
            if not clocked:
                t[segs[0].slice] += last_t + default_step
            elif not t[0] > last_t:
                raise ValueError(
                    f"{name}: 'time_s' must strictly increase within a test; in "
                    f"{segment_label(segs[0])} it is {t[0]:g} at the first row of piece {j} "
                    f"after {last_t:g}."
                )
            prev = segments.pop()
            segments.append(Segment(prev.label, prev.start, n + segs[0].stop))
            segs = segs[1:]
        for seg in segs:
            if seg.label in seen:
                raise ValueError(
                    f"{name}: {segment_label(seg)} appears again in piece {j} after other "
                    "tests; the rows of a test must be contiguous and in order."
                )
            seen.add(seg.label)
            segments.append(Segment(seg.label, n + seg.start, n + seg.stop))
            firsts.append(Xa[seg.start].copy())
        if segments:
            seen.add(segments[-1].label)
        a = _peaks(Xa)
        peaks = a if peaks is None else np.maximum(peaks, a)
        if n_changes < MAX_CHANGES:
            # no more rows than the changes still wanted need (each test's first
            # row has no change from the row before it)
            d = np.diff(Xa[: MAX_CHANGES - n_changes + len(segs) + 1], axis=0)
            inside = np.ones(d.shape[0], dtype=bool)
            for seg in segs:  # no change from the row before a test's first
                if 0 < seg.start <= d.shape[0]:
                    inside[seg.start - 1] = False
            parts = [d[inside]]
            if on and last_row is not None:
                parts.insert(0, (Xa[0] - last_row)[None, :])
            d = np.concatenate(parts)[: MAX_CHANGES - n_changes]
            changes.append(d)
            n_changes += d.shape[0]
        ts.append(t)
        ys.append(ya)
        ws.append(None if sample_weight is None else w)  # ones are not kept row by row
        sizes.append(Xa.shape[0])
        last_row, last_t = Xa[-1].copy(), float(t[-1])
        n += Xa.shape[0]
        held = Xa if keep and j == 0 else None
    if names is None:
        raise ValueError(f"{name}: the training data has no pieces.")
    if all(v is None for v in ws):  # no weights given: one read-only 1 for every row
        w = np.broadcast_to(1.0, (n,))
    else:
        w = np.concatenate([np.ones(size) if v is None else v for v, size in zip(ws, sizes)])
    if w.sum() <= 0:
        raise ValueError(f"{name}: every sample_weight is zero; give some rows a positive weight.")
    q = len(names)
    return Rows(
        names=names,
        t=np.concatenate(ts),
        clocked=bool(clocked),
        labelled=bool(labelled),
        y=np.concatenate(ys),
        w=w,
        segments=segments,
        first_rows=np.array(firsts).reshape(len(firsts), q),
        peaks=peaks,
        changes=np.concatenate(changes) if changes else np.zeros((0, q)),
        X=held if len(sizes) == 1 else None,
        source=None if keep else pieces,
        sizes=tuple(sizes),
        owner=estimator,
    )
