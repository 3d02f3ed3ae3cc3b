"""The probe filter of the Structured Text export, and its literals.

``Observe`` and ``Recalibrate`` of the function block (the Kalman filter and
the change detector of :meth:`greyml.dynamic.Compensator.observe`) and its
interval outputs (``HalfWidthUm``, ``Trusted``, ``Changes``), written as
:mod:`greyml.dynamic._export_c` writes them in C; and the LREAL literals both
parts of :mod:`greyml.dynamic._export_st` use.
"""

from __future__ import annotations

import math
from string import Template

__all__ = ["finite", "literal", "observe_block"]

_MAX_REAL = "1.7976931348623157E308"


def literal(x):
    """An LREAL literal that reads back as exactly ``x`` (IEC wants a digit after a
    point); an infinite bound is the largest LREAL, which every finite number is within."""
    x = float(x)
    if math.isinf(x):
        return _MAX_REAL if x > 0 else "-" + _MAX_REAL
    if math.isnan(x):
        raise ValueError("Compensator.export: a number to write is NaN.")
    mantissa, e, exponent = repr(x).upper().partition("E")
    if "." not in mantissa:
        mantissa += ".0"
    return mantissa + e + exponent


def finite(x):
    return f"(ABS({x}) <= {_MAX_REAL})"


def observe_block(p):
    """Observe and Recalibrate (Compensator.observe's filter), and the outputs of
    the interval (``HalfWidthUm``, ``Trusted``, ``Changes``); '' and '' without one."""
    if p.trust is None:
        return "", ""
    t = p.trust
    tolerance = "TRUE" if p.tolerance_um is None else f"HalfWidthUm <= {literal(p.tolerance_um)}"
    return Template(
        r"""IF Observe THEN
    ProbeStatus := 0;
    IF NOT (${finite_probe_time} AND ${finite_probe}) OR NOT st_started THEN
        ProbeStatus := ERR_READING;
    ELSIF ABS(ProbeUm) > ${max_correction} OR ProbeTimeS > st_time_s THEN
        ProbeStatus := ERR_READING;
    ELSIF st_has_reading AND ProbeTimeS <= st_last_reading THEN
        ProbeStatus := ERR_READING;
    END_IF;
    IF ProbeStatus = 0 THEN
        oldest := 0;
        IF st_hcount >= HISTORY THEN
            oldest := st_hpos;
        END_IF;
        IF ProbeTimeS < st_ht[oldest] THEN
            ProbeStatus := ERR_READING;
        END_IF;
    END_IF;
    IF ProbeStatus = 0 THEN
        (* the model's correction at ProbeTimeS, linear between the rows remembered *)
        m := st_hm[(st_hpos + HISTORY - 1) MOD HISTORY];
        found := FALSE;
        FOR k := 0 TO HISTORY - 2 DO
            IF NOT found AND k + 1 < st_hcount THEN
                j0 := (oldest + k) MOD HISTORY;
                j1 := (oldest + k + 1) MOD HISTORY;
                IF ProbeTimeS < st_ht[j1] THEN
                    slope := (st_hm[j1] - st_hm[j0]) / (st_ht[j1] - st_ht[j0]);
                    m := slope * (ProbeTimeS - st_ht[j0]) + st_hm[j0];
                    found := TRUE;
                END_IF;
            END_IF;
        END_FOR;
        IF NOT st_adjusted THEN
            (* the first reading: the slow part's prior is the batch variance there *)
            dh := (ProbeTimeS - st_ft0) / 3600.0;
            IF dh < 0.0 THEN
                dh := 0.0;
            END_IF;
            FOR k := 0 TO 2 DO
                fx[k] := 0.0;
            END_FOR;
            FOR k := 0 TO 8 DO
                fp[k] := st_fp[k];
            END_FOR;
            fp[0] := ${offset_var} + ${growth_var} * dh;
        ELSE
            propTime := ProbeTimeS;
${propagate}
        END_IF;
        h[0] := 1.0;
        h[1] := 0.0;
        h[2] := m;
        predicted := m * (1.0 + fx[2]) + fx[0];
        innovation := ProbeUm - predicted;
        hph := (fp[0] + m * fp[6]) + (fp[2] + m * fp[8]) * m;
        sv := hph + ${noise_var} + ${probe_var};
        IF sv <= 0.0 THEN
            sv := 2.2250738585072014E-308; (* no uncertainty at all: the reading is the truth *)
        END_IF;
        FOR k := 0 TO 2 DO
            ph[k] := fp[3 * k] * h[0] + fp[3 * k + 1] * h[1] + fp[3 * k + 2] * h[2];
            kg[k] := ph[k] / sv;
            fx[k] := fx[k] + kg[k] * innovation;
        END_FOR;
        FOR k := 0 TO 2 DO
            FOR j := 0 TO 2 DO
                IF k = j THEN
                    ikh[3 * k + j] := 1.0 - kg[k] * h[j];
                ELSE
                    ikh[3 * k + j] := 0.0 - kg[k] * h[j];
                END_IF;
            END_FOR;
        END_FOR;
        FOR k := 0 TO 2 DO
            FOR j := 0 TO 2 DO
                am[3 * k + j] := ikh[3 * k] * fp[j] + ikh[3 * k + 1] * fp[3 + j]
                    + ikh[3 * k + 2] * fp[6 + j];
            END_FOR;
        END_FOR;
        FOR k := 0 TO 2 DO
            FOR j := 0 TO 2 DO
                pn[3 * k + j] := kg[k] * kg[j] * (sv - hph) + am[3 * k] * ikh[3 * j]
                    + am[3 * k + 1] * ikh[3 * j + 1] + am[3 * k + 2] * ikh[3 * j + 2];
            END_FOR;
        END_FOR;
        FOR k := 0 TO 2 DO
            st_fx[k] := fx[k];
            FOR j := 0 TO 2 DO
                st_fp[3 * k + j] := 0.5 * (pn[3 * k + j] + pn[3 * j + k]);
            END_FOR;
        END_FOR;
        st_ft0 := ProbeTimeS;
        st_has_ft0 := TRUE;
        st_adjusted := TRUE;
        st_has_reading := TRUE;
        st_last_reading := ProbeTimeS;
        (* the change detector: a two-sided CUSUM of the standardised innovations *)
        zs := innovation / SQRT(sv);
        st_flags[0] := st_flags[0] + zs - ${allowance};
        st_flags[1] := st_flags[1] - zs - ${allowance};
        FOR k := 0 TO 1 DO
            IF st_flags[k] < 0.0 THEN
                st_flags[k] := 0.0;
            END_IF;
        END_FOR;
        IF st_flags[0] > ${threshold} OR st_flags[1] > ${threshold} THEN
            recalSize := innovation;
${recalibrate}
        END_IF;
        dh := (st_time_s - st_ft0) / 3600.0;
        st_correction_um := st_model_um * (1.0 + st_fx[2]) + st_fx[0] * EXP(-dh / MEMORY_H)
            + st_fx[1] * dh;
    END_IF;
END_IF;
IF Recalibrate THEN
    recalSize := SQRT(${offset_var} + ${noise_var});
    IF recalSize = 0.0 THEN
        recalSize := 1.0;
    END_IF;
${recalibrate_outer}
END_IF;
"""
    ).substitute(
        finite_probe_time=finite("ProbeTimeS"),
        finite_probe=finite("ProbeUm"),
        max_correction=literal(p.max_correction_um),
        offset_var=literal(t.offset_var),
        growth_var=literal(t.growth_var_per_h),
        noise_var=literal(t.noise_var),
        probe_var=literal(t.probe_noise_um**2),
        allowance=literal(t.allowance),
        threshold=literal(t.change_threshold),
        propagate=_propagate_st("            "),
        recalibrate=_recalibrate_st("            "),
        recalibrate_outer=_recalibrate_st("    "),
    ), _status_st(p, tolerance)


def _recalibrate_st(indent):
    """Compensator.recalibrate(recalSize): drift and gain become uncertain."""
    lines = """st_fp[0] := st_fp[0] + recalSize * recalSize;
st_fp[4] := st_fp[4] + recalSize * recalSize;
st_fp[8] := st_fp[8] + GAIN_VAR;
st_changes := st_changes + 1;
st_flags[0] := 0.0;
st_flags[1] := 0.0;"""
    return "\n".join(indent + line for line in lines.split("\n"))


def _propagate_st(indent):
    """fx, fp := the filter carried from its time to propTime (F x, F P F' + Q)."""
    lines = """dh := (propTime - st_ft0) / 3600.0;
IF dh < 0.0 THEN
    dh := 0.0;
END_IF;
phi := EXP(-dh / MEMORY_H);
ff[0] := phi; ff[1] := dh; ff[2] := 0.0;
ff[3] := 0.0; ff[4] := 1.0; ff[5] := 0.0;
ff[6] := 0.0; ff[7] := 0.0; ff[8] := 1.0;
FOR k := 0 TO 2 DO
    fx[k] := ff[3 * k] * st_fx[0] + ff[3 * k + 1] * st_fx[1] + ff[3 * k + 2] * st_fx[2];
    FOR j := 0 TO 2 DO
        am[3 * k + j] := ff[3 * k] * st_fp[j] + ff[3 * k + 1] * st_fp[3 + j]
            + ff[3 * k + 2] * st_fp[6 + j];
    END_FOR;
END_FOR;
FOR k := 0 TO 2 DO
    FOR j := 0 TO 2 DO
        fp[3 * k + j] := am[3 * k] * ff[3 * j] + am[3 * k + 1] * ff[3 * j + 1]
            + am[3 * k + 2] * ff[3 * j + 2];
    END_FOR;
END_FOR;
fp[0] := fp[0] + MEMORY_VAR * (1.0 - phi * phi);"""
    return "\n".join(indent + line for line in lines.split("\n"))


def _status_st(p, tolerance):
    """HalfWidthUm, Trusted and Changes, at every call."""
    t = p.trust
    return Template(
        r"""HalfWidthUm := 0.0;
Trusted := FALSE;
IF st_started THEN
    IF NOT st_adjusted THEN
        dh := (st_time_s - st_ft0) / 3600.0;
        IF dh < 0.0 THEN
            dh := 0.0;
        END_IF;
        variance := ${offset_var} + ${growth_var} * dh + ${noise_var};
    ELSE
        propTime := st_time_s;
${propagate}
        m := st_model_um;
        hph := (fp[0] + m * fp[6]) + (fp[2] + m * fp[8]) * m;
        IF hph < 0.0 THEN
            hph := 0.0;
        END_IF;
        variance := hph + ${noise_var};
    END_IF;
    HalfWidthUm := ${quantile} * SQRT(variance);
    Trusted := Plausible AND ${tolerance};
END_IF;
Changes := st_changes;
"""
    ).substitute(
        offset_var=literal(t.offset_var),
        growth_var=literal(t.growth_var_per_h),
        noise_var=literal(t.noise_var),
        quantile=literal(t.interval_quantile),
        propagate=_propagate_st("        "),
        tolerance=tolerance,
    )
