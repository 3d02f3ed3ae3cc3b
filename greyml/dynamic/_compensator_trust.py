"""How far to trust a Compensator, and probe readings that correct it.

A mixin of :class:`greyml.dynamic.Compensator`. Before any reading, the
model's error at a time ``t`` (hours) since the displacement was last known
has the variance ``offset_var + growth_var·t + noise_var``: the structure
:meth:`greyml.ThermalTransferFunction.predict_interval` is calibrated with,
so that the compensator's interval is the batch one.

A probe reading (:meth:`Compensator.observe`) corrects a small Kalman filter
(Kalman, 1960) on three states: the error's slow part (an offset that
forgets itself with the memory ``memory_h``, towards the variance
``memory_var``: an Ornstein-Uhlenbeck process, fitted to the held-out
residuals' variogram), a rate (µm per hour) and a gain error of the model's
correction. The rate and the gain start certain (variance 0), so readings
move only the offset, until the change detector fires and recalibrates.
The detector is a two-sided CUSUM (Page, 1954) of the standardised
innovations, with the textbook allowance of half a standard deviation:
it fires when the sum of the readings' excess in one direction passes
``change_threshold`` (5 standard deviations by default), so a persistent
small shift fires it as surely as one large jump. On recalibrating, the
rate and the gain become uncertain and the next readings estimate them (no
refit from scratch). The user can force that with
:meth:`Compensator.recalibrate`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from greyml.dynamic._compensator_plan import real
from greyml.dynamic._output import limit_output

__all__ = ["HISTORY", "Status", "filter_from_vars"]

#: Rows remembered for readings that arrive late (e.g. 2 h of 15 s rows).
HISTORY = 512
#: The CUSUM's allowance, in standard deviations of the innovation (Page, 1954).
_ALLOWANCE = 0.5
#: Variance given to the gain error when recalibrating (a 30 % standard deviation).
_GAIN_VAR = 0.09

Status = namedtuple(
    "Status",
    "time_s correction half_width trusted plausible changes output held",
    module=__name__,
)
Status.__doc__ = """What the last update gave and how far to trust it.

time_s : float or None
    Time of the last row.
correction : float or None
    The correction given for it (probe readings included).
half_width : float
    Half-width of the interval at that row (NaN without an ``uncertainty``).
trusted : bool
    The correction is plausible and its half-width within ``tolerance_um``.
plausible : bool
    The correction is within ``max_correction_um``.
changes : int
    How many times the change detector fired (and recalibrated).
output : float
    What the last update gave the axis: the correction clamped, quantised and
    rate limited (0 before any).
held : bool
    The last update had a missing input (NaN or infinite) and gave the
    output before it again; its row changed no state (``time_s`` is the last
    row taken).
"""

_PREFIX = "Compensator.observe:"


def filter_from_vars(saved):
    """The filter's state (as ``get_state`` gives it) from a compensator's saved
    attributes, or None when it has none (a file from before probe readings).

    Nothing is trusted: the values are checked by ``set_state`` afterwards.
    """
    keys = ("_fx", "_fP", "_ft0", "_adjusted", "_flags", "_changes", "_last_reading")
    if not all(k in saved for k in (*keys, "_model", "_corr", "_ht", "_hm", "_hn")):
        return None
    try:
        n = int(saved["_hn"])
        ht = np.asarray(saved["_ht"], dtype=float)
        hm = np.asarray(saved["_hm"], dtype=float)
        if not (0 <= n and ht.shape == hm.shape == (HISTORY,)):
            raise ValueError
        t, m = ht[: min(n, HISTORY)], hm[: min(n, HISTORY)]
        order = np.argsort(t, kind="stable")
    except (TypeError, ValueError, OverflowError):
        raise ValueError("Compensator: the saved probe filter is not valid.") from None
    return {
        "x": saved["_fx"],
        "P": saved["_fP"],
        "t0": saved["_ft0"],
        "adjusted": saved["_adjusted"],
        "flags": saved["_flags"],
        "changes": saved["_changes"],
        "last_reading": saved["_last_reading"],
        "model": saved["_model"],
        "correction": saved["_corr"],
        "history_time_s": t[order].tolist(),
        "history_model": m[order].tolist(),
    }


class _Trust:
    """Intervals, trust, probe readings and recalibration of a Compensator."""

    # -- parameters -----------------------------------------------------------

    def _uncertainty(self):
        """``(offset_var, growth_var, noise_var, memory_var, memory_h)`` checked, or None."""
        u = self.uncertainty
        if u is None:
            return None
        try:
            values = [float(v) for v in u]
        except (TypeError, ValueError):
            values = []
        if (
            len(values) != 5
            or not all(map(math.isfinite, values))
            or min(values) < 0
            or values[4] <= 0
        ):
            raise ValueError(
                "The 'uncertainty' parameter of Compensator must be five finite numbers "
                "(offset_var, growth_var_per_h, noise_var, memory_var >= 0, and memory_h > 0); "
                f"got {u!r}."
            )
        return tuple(values)

    # -- state ----------------------------------------------------------------

    def _reset_trust(self):
        u = self._uncertainty()
        offset_var = u[0] if u else 0.0
        self._fx = np.zeros(3)  # offset, rate per hour, gain error: at _ft0
        self._fP = np.diag([offset_var, 0.0, 0.0])
        self._ft0 = None
        self._adjusted = False
        self._flags = [0.0, 0.0]  # the CUSUM's sums upwards and downwards
        self._changes = 0
        self._last_reading = None
        self._corr = None
        self._model = None
        self._ht = np.full(HISTORY, -np.inf)
        self._hm = np.zeros(HISTORY)
        self._hn = 0

    def start_test(self, row, initial_displacement=None):
        """Take the first row of a test that continues the state: its lags carry on,
        and the reference starts anew there.

        For a recording whose tests follow each other on one clock: the
        correction at ``row`` is 0 with ``relative_to_start=True`` (or the
        ``initial_displacement`` given), as batch ``predict`` measures each
        test from its first row, while the lags keep the history that
        :meth:`reset` would forget. Probe readings of the previous test no
        longer apply (the displacement is known again here).

        Parameters
        ----------
        row : dict, pandas Series or 1-D array
            As for :meth:`update`.
        initial_displacement : float, optional
            The displacement measured at ``row``.

        Returns
        -------
        correction : float
        """
        if initial_displacement is not None and not real(initial_displacement):
            raise ValueError(
                "Compensator.start_test: initial_displacement must be a finite number; got "
                f"{initial_displacement!r}."
            )
        previous = self._time
        before = (self._last, self._credit)  # the output stage before this row
        self.update(row)
        if self._held:
            return self._output  # a missing input: nothing moved, not even the reference
        total = float(self._plan["weight"] @ self._lags)
        self._initial = None if initial_displacement is None else float(initial_displacement)
        self._start = self._first_start(total)
        model = self.intercept + total - (self._start or 0.0)
        if self._start is not None:  # the displacement is known here: the filter starts anew
            self._anchor_trust(self._time, model)
        else:
            self._corr = self._corrected(model, self._time) if self._adjusted else model
        plan = self._plan
        if not plan["limited"]:
            self._output = self._last = self._corr
            return self._corr
        dt = None if previous is None else self._time - previous
        if dt is not None and not dt > 0:
            dt = self.nominal_step_s
        self._output, self._last, self._credit = limit_output(
            self._corr, dt, before[0], before[1], *plan["limits"]
        )
        return self._output

    def _anchor_trust(self, time, model):
        """The displacement is known at ``time`` (a new test's first row): the filter
        starts anew there; the rows remembered stay, the last one given ``model``."""
        history = (self._ht.copy(), self._hm.copy(), self._hn)
        self._reset_trust()
        self._ht, self._hm, self._hn = history
        self._hm[(self._hn - 1) % HISTORY] = model
        self._ft0, self._model, self._corr = time, model, model

    def _record(self, time, model):
        """Remember the model's correction at ``time``; return the correction given."""
        if self._ft0 is None:
            self._ft0 = time
        i = self._hn % HISTORY
        self._ht[i] = time
        self._hm[i] = model
        self._hn += 1
        self._model = model
        if self._adjusted:
            model = self._corrected(model, time)
        self._corr = model = float(model)
        return model

    def _corrected(self, model, time):
        """The model's correction with the filter's states carried to ``time``."""
        x = self._fx
        dh = (time - self._ft0) / 3600.0
        return model * (1.0 + x[2]) + x[0] * math.exp(-dh / self._memory_h) + x[1] * dh

    @property
    def _memory_h(self):
        u = self._uncertainty()
        return u[4] if u else math.inf

    def _propagated(self, time):
        """The filter's states and covariance carried from its time to ``time``."""
        dh = max(0.0, (time - self._ft0) / 3600.0)
        u = self._uncertainty() or (0.0, 0.0, 0.0, 0.0, math.inf)
        phi = math.exp(-dh / u[4])
        F = np.array([[phi, dh, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        Q = np.diag([u[3] * (1.0 - phi * phi), 0.0, 0.0])
        return F @ self._fx, F @ self._fP @ F.T + Q, dh

    def _variance_at(self, time, model):
        """Variance of the error of the correction given at ``time`` (model part ``model``)."""
        u = self._uncertainty()
        if not self._adjusted:  # the batch calibration, from the first row
            dh = max(0.0, (time - self._ft0) / 3600.0)
            return u[0] + u[1] * dh + u[2]
        _, P, _ = self._propagated(time)
        h = np.array([1.0, 0.0, model])
        return max(float(h @ P @ h), 0.0) + u[2]

    @property
    def status(self):
        """:class:`Status` of the last update: correction, half-width, trust."""
        u = self._uncertainty()
        if self._time is None or self._corr is None:
            return Status(
                self._time, None, math.nan, False, False, self._changes, self._output, self._held
            )
        corr = self._corr
        plausible = abs(corr) <= self.max_correction_um
        half = math.nan
        if u is not None:
            half = self.interval_quantile * math.sqrt(self._variance_at(self._time, self._model))
        trusted = plausible and (
            self.tolerance_um is None or (math.isfinite(half) and half <= self.tolerance_um)
        )
        return Status(
            self._time,
            corr,
            half,
            bool(trusted),
            bool(plausible),
            self._changes,
            self._output,
            self._held,
        )

    # -- readings -------------------------------------------------------------

    def _history(self):
        """The rows remembered, in time order: (time_s, model correction)."""
        n = min(self._hn, HISTORY)
        t, m = self._ht[:n], self._hm[:n]
        if self._hn > HISTORY:
            order = np.argsort(t, kind="stable")
            t, m = t[order], m[order]
        return t, m

    def _model_at(self, time_s):
        """The model's correction at ``time_s`` from the rows remembered (linear between)."""
        t, m = self._history()
        if t.size == 0:
            raise ValueError(
                f"{_PREFIX} no row is remembered since the state was set, so the reading at "
                f"time_s = {time_s:g} s cannot be placed; update with its row first."
            )
        if time_s < t[0]:
            raise ValueError(
                f"{_PREFIX} the reading at time_s = {time_s:g} s is older than the "
                f"{t.size} rows remembered (from {t[0]:g} s); it cannot be placed."
            )
        return float(np.interp(time_s, t, m))

    def _shift_clock(self, shift):
        """The rows' clock restarted (a new piece): move the filter's times with it."""
        if self._ft0 is not None:
            self._ft0 -= shift
        if self._last_reading is not None:
            self._last_reading -= shift
        self._ht = self._ht - shift

    def observe(self, time_s, measured_um):
        """Correct the compensator with a displacement measured at ``time_s``.

        The reading moves the filter's offset (and, after a recalibration,
        its rate and gain), which every later correction carries; the
        interval narrows at the reading and widens again with the time since.
        A reading may arrive late (up to 512 rows back), never from the
        future of the last update, nor before the previous reading.

        Parameters
        ----------
        time_s : float
            When the displacement was measured, on the rows' clock.
        measured_um : float
            The measured displacement, in the compensator's reference.

        Returns
        -------
        status : Status
            After the reading (at the last update's row).

        Raises
        ------
        ValueError
            With one line naming the time and the value, for a reading that is
            not a finite number, beyond ``max_correction_um``, after the last
            update, before the previous reading, or older than the rows
            remembered. The state is unchanged then.
        """
        self._plan_or_build()
        for what, value in (("time_s", time_s), ("measured_um", measured_um)):
            if not real(value):
                raise ValueError(
                    f"{_PREFIX} {what} is {value!r} (reading at time_s = {time_s!r}); it must "
                    "be a finite number."
                )
        time_s, z = float(time_s), float(measured_um)
        if self._time is None:
            raise ValueError(
                f"{_PREFIX} the reading {z:g} at time_s = {time_s:g} s comes before the first "
                "update; update with the row of that time first."
            )
        if self._uncertainty() is None:
            raise ValueError(
                f"{_PREFIX} the reading {z:g} at time_s = {time_s:g} s cannot be weighed: this "
                "compensator has no uncertainty (its model was fitted on fewer than 3 tests, "
                "or give uncertainty=)."
            )
        if abs(z) > self.max_correction_um:
            raise ValueError(
                f"{_PREFIX} the reading {z:g} at time_s = {time_s:g} s is beyond "
                f"±{self.max_correction_um:g} (max_correction_um); not a thermal displacement."
            )
        if time_s > self._time:
            raise ValueError(
                f"{_PREFIX} the reading {z:g} at time_s = {time_s:g} s is after the last "
                f"update ({self._time:g} s); update with that row first."
            )
        if self._last_reading is not None and time_s <= self._last_reading:
            raise ValueError(
                f"{_PREFIX} the reading {z:g} at time_s = {time_s:g} s is not after the "
                f"previous reading ({self._last_reading:g} s); readings must come in order."
            )
        m = self._model_at(time_s)
        u = self._uncertainty() or (0.0, 0.0, 0.0, 0.0, math.inf)
        if not self._adjusted:
            # the first reading: the slow part's prior is the batch variance there
            dh = max(0.0, (time_s - self._ft0) / 3600.0)
            x, P = np.zeros(3), self._fP.copy()
            P[0, 0] = u[0] + u[1] * dh
        else:
            x, P, _ = self._propagated(time_s)
        h = np.array([1.0, 0.0, m])
        predicted = m * (1.0 + x[2]) + x[0]
        innovation = z - predicted
        S = float(h @ P @ h) + u[2] + self.probe_noise_um**2
        if S <= 0:  # every variance 0: the model is held certain, the reading moves nothing
            S = np.finfo(float).tiny
        K = P @ h / S
        x = x + K * innovation
        IKH = np.eye(3) - np.outer(K, h)
        P = IKH @ P @ IKH.T + np.outer(K, K) * (S - float(h @ P @ h))  # Joseph form
        self._fx, self._fP, self._ft0 = x, 0.5 * (P + P.T), time_s
        self._adjusted = True
        self._last_reading = time_s
        z = innovation / math.sqrt(S)
        up, down = self._flags
        self._flags = [max(0.0, up + z - _ALLOWANCE), max(0.0, down - z - _ALLOWANCE)]
        if max(self._flags) > self.change_threshold:
            self.recalibrate(innovation)
        # the last update's correction, with the filter's new state
        self._corr = float(self._corrected(self._model, self._time))
        return self.status

    def recalibrate(self, size_um=None):
        """Let the next readings estimate a drift and a gain error (the machine changed).

        The change detector calls this when its CUSUM passes
        ``change_threshold``; call it yourself after a known change (a crash,
        a new spindle, a season).

        Parameters
        ----------
        size_um : float, optional
            How far off the model is thought to be (by default the interval's
            standard deviation at the last update).

        Returns
        -------
        self : Compensator
        """
        self._plan_or_build()
        if size_um is None or not real(size_um):
            u = self._uncertainty() or (0.0, 0.0, 0.0, 0.0, math.inf)
            size_um = math.sqrt(max(u[0] + u[2], 0.0)) or 1.0
        size2 = float(size_um) ** 2
        # a drift of that size per hour, and a 30 % gain error, become possible
        self._fP = self._fP + np.diag([size2, size2, _GAIN_VAR])
        self._changes += 1
        self._flags = [0.0, 0.0]
        return self

    # -- saved state ----------------------------------------------------------

    def _filter_state(self):
        t, m = self._history()
        return {
            "x": self._fx.tolist(),
            "P": self._fP.tolist(),
            "t0": self._ft0,
            "adjusted": self._adjusted,
            "flags": list(self._flags),
            "changes": self._changes,
            "last_reading": self._last_reading,
            "model": self._model,
            "correction": self._corr,
            "history_time_s": t.tolist(),
            "history_model": m.tolist(),
        }

    def _set_filter_state(self, state):
        """Restore :meth:`_filter_state`'s dict, every value checked."""
        bad = ValueError("Compensator.set_state: the state's probe filter is not valid.")
        try:
            x = np.asarray(state["x"], dtype=float)
            P = np.asarray(state["P"], dtype=float)
            ht = np.asarray(state["history_time_s"], dtype=float)
            hm = np.asarray(state["history_model"], dtype=float)
            flags = [float(f) for f in state["flags"]]
            changes = state["changes"]
            adjusted = state["adjusted"]
            scalars = [state["t0"], state["last_reading"], state["model"], state["correction"]]
        except (KeyError, TypeError, ValueError):
            raise bad from None
        if (
            x.shape != (3,)
            or P.shape != (3, 3)
            or not (np.isfinite(x).all() and np.isfinite(P).all())
            or not np.allclose(P, P.T)
            or (np.diag(P) < 0).any()
            or ht.shape != hm.shape
            or ht.ndim != 1
            or ht.size > HISTORY
            or not (np.isfinite(ht).all() and np.isfinite(hm).all())
            or (np.diff(ht) < 0).any()
            or not (isinstance(changes, int) and not isinstance(changes, bool) and changes >= 0)
            or not isinstance(adjusted, bool)
            or len(flags) != 2
            or not all(math.isfinite(f) and f >= 0 for f in flags)
            or not all(v is None or real(v) for v in scalars)
        ):
            raise bad
        self._fx, self._fP = x, P
        self._ft0, self._last_reading, self._model, self._corr = scalars
        self._adjusted = adjusted
        self._flags, self._changes = flags, changes
        self._ht = np.full(HISTORY, -np.inf)
        self._hm = np.zeros(HISTORY)
        self._ht[: ht.size], self._hm[: hm.size] = ht, hm
        self._hn = ht.size
