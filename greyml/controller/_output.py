"""What a controller takes: the compensator's correction clamped, quantised and rate limited.

One record, :class:`OutputLimits` (the three limits, checked together), and one
pure function, :func:`limit_output`, that :class:`greyml.Compensator` calls
after every update and that every export (C, Structured Text) spells out
step for step, so the axis gets the same number from each (issue 29):

1. **clamp**: the correction is limited to ``±clamp_um``;
2. **quantum**: it is rounded to the nearest whole number of ``quantum_um``
   (halves away from zero), at most :data:`QUANTA_MAX` of them, so that the
   count fits the 32-bit integer of a PLC (``TRUNC``) and the output is always
   a whole number of quanta;
3. **rate limit**: the output moves towards that target by at most
   ``rate_limit_um_s`` times the step since the previous row. With a quantum
   the output moves in whole quanta: the allowance accrues as a credit in µm,
   never more than one row's allowance or one quantum (whichever is larger),
   and a move spends it; so a limit slower than one quantum per row moves one
   quantum as soon as the credit holds one, and never sooner.

The output starts at 0 (nothing written to the axis yet) and is held at the
first row after a reset (no step to allow a move by): with a rate limit it
ramps from there, never jumps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["QUANTA_MAX", "QUANTUM_TOLERANCE", "OutputLimits", "limit_output"]

#: The most quanta an output holds: a count that fits a PLC's 32-bit integer
#: (DINT) with room for a difference of two of them.
QUANTA_MAX = 1e9

#: A credit this close to a whole number of quanta (relative to one quantum)
#: allows that many: the credit is a sum of products, which may fall short of
#: the whole number by a rounding error.
QUANTUM_TOLERANCE = 1e-9


@dataclass(frozen=True)
class OutputLimits:
    """The controller's limits on the output, each a float or None when off.

    Attributes
    ----------
    clamp_um : float or None
        The output is at most this far from 0 (a whole number of quanta).
    quantum_um : float or None
        The output is a whole number of this many µm.
    rate_limit_um_s : float or None
        The output moves by at most this many µm per second of the rows' clock.
    """

    clamp_um: float | None = None
    quantum_um: float | None = None
    rate_limit_um_s: float | None = None

    @classmethod
    def checked(cls, clamp_um, quantum_um, rate_limit_um_s, owner="Compensator"):
        """The three limits as floats or None; a clamp that is not a whole number of
        quanta is refused (the clamped output could not be one)."""
        clamp, q = clamp_um, quantum_um
        limits = cls(*(None if v is None else float(v) for v in (clamp, q, rate_limit_um_s)))
        if q is not None:
            count = float(clamp) / float(q) if clamp is not None else 1.0
            if clamp is not None and (
                count > QUANTA_MAX or abs(count - round(count)) > 1e-9 * max(1.0, count)
            ):
                raise ValueError(
                    f"The 'clamp_um' parameter of {owner} ({clamp!r}) must be a whole "
                    f"number of quanta (quantum_um={q!r}), at most {QUANTA_MAX:.0e} of them."
                )
        return limits

    @property
    def any(self):
        """Any of the three is set."""
        return not (
            self.clamp_um is None and self.quantum_um is None and self.rate_limit_um_s is None
        )


def limit_output(value, dt, last, credit, limits):
    """One row of the output stage.

    Parameters
    ----------
    value : float
        The correction (finite), in µm.
    dt : float or None
        Seconds since the previous row (the lags' step); None at the first
        row after construction or a reset.
    last : float
        The previous output: in quanta with a quantum (a whole number), in µm
        without one.
    credit : float
        The µm the rate limit still allows (with a quantum and a rate limit;
        0 otherwise).
    limits : OutputLimits
        Checked.

    Returns
    -------
    output : float
        In µm.
    last : float
        The new output in the stage's unit (quanta or µm).
    credit : float
    """
    clamp, q, rate = limits.clamp_um, limits.quantum_um, limits.rate_limit_um_s
    if not math.isfinite(value):  # never a NaN or an infinity to a count of quanta
        raise ValueError(f"limit_output: the correction is {value!r}, not a finite number.")
    if clamp is not None:
        value = min(max(value, -clamp), clamp)
    if q is None:
        if rate is not None:
            allowed = 0.0 if dt is None else rate * dt
            value = min(max(value, last - allowed), last + allowed)
        return value, value, credit
    count = float(math.floor(min(abs(value) / q + 0.5, QUANTA_MAX)))
    if value < 0:
        count = -count
    if rate is not None:
        if dt is not None:
            credit = min(credit + rate * dt, max(rate * dt, q))
        d = count - last
        k = float(math.floor(min(abs(d), credit / q + QUANTUM_TOLERANCE)))
        count = last + k if d > 0 else last - k
        credit = max(credit - k * q, 0.0)
    return count * q, count, credit
