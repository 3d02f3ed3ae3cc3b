"""What a Compensator is built from: a fitted model's terms, limits and calibration.

:meth:`greyml.Compensator.from_model` reads a fitted
:class:`greyml.ThermalTransferFunction` through its public fitted attributes
(``terms_``, ``intercept_``, ``reference_``, ``drivers_``, ``gap_limit_s_``,
``nominal_step_s_``, its interval calibration and its ``input_envelope_``);
:meth:`greyml.Compensator.from_pipeline` a fitted
``Pipeline(LagFeatures, [StandardScaler], linear model)``, the scaler and the
linear model's coefficients folded into the lag terms' weights and the
intercept.
"""

from __future__ import annotations

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from greyml.dynamic._envelope import InputEnvelope
from greyml.dynamic._lags import LagFeatures

__all__ = ["pipeline_terms", "transfer_terms"]


def pipeline_terms(pipeline):
    """The ``inputs``, ``terms``, ``intercept`` and ``nominal_step_s`` of a fitted pipeline.

    Parameters
    ----------
    pipeline : Pipeline
        See :meth:`greyml.Compensator.from_pipeline`.

    Returns
    -------
    dict
        Keyword arguments of :class:`greyml.Compensator`.
    """
    if not isinstance(pipeline, Pipeline):
        raise TypeError(
            "Compensator.from_pipeline takes a fitted scikit-learn Pipeline; got "
            f"{type(pipeline).__name__}."
        )
    steps = [est for _, est in pipeline.steps if est not in (None, "passthrough")]
    kinds = " → ".join(type(s).__name__ for s in steps)
    if not (2 <= len(steps) <= 3 and isinstance(steps[0], LagFeatures)) or (
        len(steps) == 3 and not isinstance(steps[1], StandardScaler)
    ):
        raise ValueError(
            "Compensator.from_pipeline needs the steps LagFeatures, an optional "
            f"StandardScaler and a linear model; got {kinds}."
        )
    lags, model = steps[0], steps[-1]
    check_is_fitted(lags)
    check_is_fitted(model)
    if not (hasattr(model, "coef_") and hasattr(model, "intercept_")):
        raise ValueError(
            f"Compensator.from_pipeline: {type(model).__name__} has no coef_ and "
            "intercept_; the last step must be a linear model."
        )
    coef = np.asarray(model.coef_, dtype=float)
    intercept = np.asarray(model.intercept_, dtype=float)
    if coef.ndim == 2 and coef.shape[0] == 1:
        coef = coef[0]
    if coef.ndim != 1 or intercept.size != 1:
        raise ValueError(
            f"Compensator.from_pipeline: {type(model).__name__} predicts "
            f"{coef.shape[0] if coef.ndim == 2 else intercept.size} targets; a "
            "compensator gives one correction."
        )
    intercept = float(intercept.reshape(-1)[0])
    names = [str(c) for c in getattr(lags, "feature_names_in_", [])] or [
        f"x{j}" for j in range(lags.n_features_in_)
    ]
    features = list(lags.terms_)
    if coef.size != len(features):
        raise ValueError(
            f"Compensator.from_pipeline: {type(model).__name__} has {coef.size} "
            f"coefficients for the {len(features)} features of LagFeatures."
        )
    weights = coef
    if len(steps) == 3:
        scaler = steps[1]
        check_is_fitted(scaler)
        if scaler.scale_ is not None:
            weights = weights / scaler.scale_
        if scaler.mean_ is not None:
            intercept -= float(weights @ scaler.mean_)
    terms = [(c, p, tau, float(w)) for (c, p, tau), w in zip(features, weights)]
    step = lags.nominal_step_s_ if lags.state == "carry" else None
    if step is not None and not np.isfinite(step):
        step = None
    return {
        "inputs": list(names),
        "terms": terms,
        "intercept": intercept,
        "nominal_step_s": step,
    }


def transfer_terms(model, *, coverage=0.9, tolerance_um=None, probe_noise_um=0.0):
    """The keyword arguments of :class:`greyml.Compensator` for a fitted transfer function.

    Parameters
    ----------
    model : ThermalTransferFunction
        Fitted.
    coverage, tolerance_um, probe_noise_um
        See :meth:`greyml.Compensator.from_model`.

    Returns
    -------
    dict
        Keyword arguments of :class:`greyml.Compensator`: the terms, the
        reference and the step limits, the ``envelope`` of the inputs it reads
        (the model's ``input_envelope_``); with a calibration (three tests or
        more in ``fit``), also ``"calibration"`` (the model's
        :class:`~greyml.dynamic.IntervalCalibration`, which the compensator
        turns into its ``uncertainty``) and the quantile at ``coverage``.
    """
    check_is_fitted(model)
    nominal_step_s = model.nominal_step_s_ if model.state == "carry" else None
    inputs = list(dict.fromkeys(name for name, _, _, _ in model.terms_))
    params = {
        "inputs": inputs,
        "terms": list(model.terms_),
        "intercept": model.intercept_,
        "relative_to_start": model.reference_ == "start",
        "nominal_step_s": nominal_step_s,
        "idle_inputs": [d for d in model.drivers_ if d in inputs],
        "max_step_s": model.gap_limit_s_,
        "tolerance_um": tolerance_um,
        "probe_noise_um": probe_noise_um,
    }
    envelope = vars(model).get("input_envelope_")
    if envelope is not None:  # the inputs the compensator reads (those with a term)
        keep = [j for j, v in enumerate(envelope.names) if v in inputs]
        params["envelope"] = InputEnvelope(
            tuple(envelope.names[j] for j in keep),
            envelope.low[keep],
            envelope.high[keep],
            envelope.max_rate_per_h[keep],
        )
    calibration = model.interval_calibration_
    if calibration is not None:
        params["calibration"] = calibration
        params["interval_quantile"] = calibration.quantile(coverage, type(model).__name__)
    return params
