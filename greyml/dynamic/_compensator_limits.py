"""The controller's limits of a Compensator: its output stage's parameters and state.

A mixin of :class:`greyml.dynamic.Compensator`; the arithmetic is
:func:`greyml.dynamic._output.limit_output`. The stage's state is the last
output (in quanta with a quantum, else µm), the rate limit's credit, and
whether the last row was held for a missing input: part of ``get_state`` and
of a saved compensator, checked when set.
"""

from __future__ import annotations

from greyml.dynamic._compensator_plan import real
from greyml.dynamic._output import QUANTA_MAX

__all__ = ["output_from_vars"]


def output_from_vars(saved):
    """The output stage's state (as ``get_state`` gives it) from a compensator's saved
    attributes, or None when it has none (nothing is trusted: ``set_state`` checks it)."""
    if not all(k in saved for k in ("_output", "_credit", "_held")):
        return None
    return {"output_um": saved["_output"], "credit_um": saved["_credit"], "held": saved["_held"]}


class _Limits:
    """Clamp, quantum, rate limit and hold-last-value of a Compensator."""

    def _checked_limits(self):
        """``(clamp_um, quantum_um, rate_limit_um_s)`` as floats or None; a clamp that is
        not a whole number of quanta is refused (the clamped output could not be one)."""
        clamp, q = self.clamp_um, self.quantum_um
        limits = tuple(None if v is None else float(v) for v in (clamp, q, self.rate_limit_um_s))
        if q is not None:
            count = float(clamp) / float(q) if clamp is not None else 1.0
            if clamp is not None and (
                count > QUANTA_MAX or abs(count - round(count)) > 1e-9 * max(1.0, count)
            ):
                raise ValueError(
                    f"The 'clamp_um' parameter of Compensator ({clamp!r}) must be a whole "
                    f"number of quanta (quantum_um={q!r}), at most {QUANTA_MAX:.0e} of them."
                )
        return limits

    def _reset_output(self):
        """Nothing written to the axis yet: the output is 0."""
        self._last = 0.0
        self._output = 0.0
        self._credit = 0.0
        self._held = False

    def _output_state(self):
        return {"output_um": self._output, "credit_um": self._credit, "held": self._held}

    def _set_output_state(self, state, limits):
        """Restore :meth:`_output_state`'s dict, every value checked against the
        ``limits`` (:meth:`_checked_limits`)."""
        clamp, quantum, _ = limits
        bad = ValueError("Compensator.set_state: the state's output is not valid.")
        try:
            output, credit, held = state["output_um"], state["credit_um"], state["held"]
        except (KeyError, TypeError):
            raise bad from None
        if not (real(output) and real(credit) and credit >= 0 and isinstance(held, bool)):
            raise bad
        output, last = float(output), float(output)
        if clamp is not None and abs(output) > clamp * (1 + 1e-12):
            raise ValueError(
                f"Compensator.set_state: the state's output {output:g} µm is beyond the "
                f"clamp ±{clamp:g} µm."
            )
        if quantum is not None:
            last = output / quantum
            if abs(last) > QUANTA_MAX or abs(last - round(last)) > 1e-6:
                raise ValueError(
                    f"Compensator.set_state: the state's output {output:g} µm is not a whole "
                    f"number of quanta ({quantum:g} µm)."
                )
            last = float(round(last))
            output = last * quantum
        self._last, self._output, self._credit, self._held = last, output, float(credit), held

    def _hold(self):
        """The last output again, for a row with a missing input (the state is unchanged)."""
        self._held = True
        return self._output
