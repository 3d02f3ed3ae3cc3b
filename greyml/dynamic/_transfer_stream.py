"""The runtime of a ThermalTransferFunction: the Compensator that streams it.

A mixin of the estimator: ``compensator`` builds a
:class:`greyml.dynamic.Compensator` from the fitted terms, the reference,
the interval's calibration (:mod:`greyml.dynamic._transfer_intervals`) and
the controller's limits.
"""

from __future__ import annotations

from sklearn.utils.validation import check_is_fitted

__all__: list[str] = []


class _TransferStream:
    """The compensator of a fitted transfer function."""

    def compensator(
        self,
        *,
        nominal_step_s=None,
        row_columns=None,
        coverage=0.9,
        tolerance_um=None,
        probe_noise_um=0.0,
        max_correction_um=1000.0,
        change_threshold=5.0,
        rate_limit_um_s=None,
        quantum_um=None,
        clamp_um=None,
        on_missing="hold",
    ):
        """A :class:`greyml.dynamic.Compensator` that runs this model row by row.

        Streaming a test from its first row (after construction or
        :meth:`~greyml.Compensator.reset`) equals :meth:`predict` on that test
        alone, and streaming the tests of one recording one after another
        equals :meth:`predict` on all of them, in the reference
        ``reference_`` (to 1e-9).

        Parameters
        ----------
        nominal_step_s : float, optional
            For a recording whose clock restarts in every piece: the step into
            a row whose ``time_s`` is not later than the previous row's (the
            next piece). By default such a row is refused, unless the model
            carried state across restarting clocks in ``fit``
            (``state="carry"``), which steps by ``nominal_step_s_``.
        row_columns : list of str, optional
            The order of the values in an array row (``"time_s"`` and every
            input, in any order); without it only mappings and Series are
            taken.
        coverage : float, default=0.9
            Of the interval its :attr:`~greyml.dynamic.Compensator.status`
            reports (as :meth:`predict_interval`); with probe readings it
            narrows at each reading (:meth:`~greyml.dynamic.Compensator.observe`).
            Without a calibration (fewer than 3 tests in ``fit``) the
            compensator gives no interval.
        tolerance_um : float, optional
            A correction is trusted while its interval's half-width is at
            most this (and the correction plausible).
        probe_noise_um : float, default=0.0
            The standard deviation of a probe reading.
        max_correction_um, change_threshold, rate_limit_um_s, quantum_um, clamp_um, on_missing
            The plausibility bound, the change detector's threshold and the
            output stage (clamp, quantum, rate limit, what a missing input
            does), as :class:`~greyml.dynamic.Compensator` takes them; they
            can also be changed later with its ``set_params``.

        Returns
        -------
        compensator : Compensator
        """
        check_is_fitted(self)
        from greyml.dynamic._compensator import Compensator

        if nominal_step_s is None and self.state == "carry":
            nominal_step_s = self.nominal_step_s_
        inputs = list(dict.fromkeys(name for name, _, _, _ in self.terms_))
        return Compensator(
            inputs,
            list(self.terms_),
            self.intercept_,
            relative_to_start=self.reference_ == "start",
            nominal_step_s=nominal_step_s,
            idle_inputs=[d for d in self.drivers_ if d in inputs],
            max_step_s=self.gap_limit_s_,
            row_columns=row_columns,
            max_correction_um=max_correction_um,
            change_threshold=change_threshold,
            rate_limit_um_s=rate_limit_um_s,
            quantum_um=quantum_um,
            clamp_um=clamp_um,
            on_missing=on_missing,
            **self._trust_parameters(coverage, tolerance_um, probe_noise_um),
        )
