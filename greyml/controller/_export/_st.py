"""A Compensator as an IEC 61131-3 Structured Text function block, from its :class:`Program`.

The TwinCAT 3 / CODESYS dialect, without object-oriented extensions: one
``FUNCTION_BLOCK`` whose inputs say what a call does (``Reset``, then
``Execute`` to take a row, then ``Observe`` and ``Recalibrate`` for a probe
reading; the outputs ``ChangeKind``, ``ChangeStartS`` and ``Innovation`` say
what the change detector found), with the arithmetic and the order of checks of the C export and of
:meth:`greyml.Compensator.update`, everything in ``LREAL`` (64-bit, as
Python's floats). Every loop runs over a constant; a number that is not finite
is told by ``ABS(x) <= 1.7976931348623157E308`` (false for NaN and infinity)
since IEC 61131-3 has no ``isnan``.
"""

from __future__ import annotations

import math
from string import Template

from greyml.controller._export._c import header_lines, wrap
from greyml.controller._export._program import ARRAYS, STATUS_CODES
from greyml.controller._output import QUANTA_MAX, QUANTUM_TOLERANCE

__all__ = ["write_st"]

# -- literals and the probe filter (Observe, Recalibrate, the interval outputs) ----

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
    """Observe and Recalibrate (Compensator.observe's filter and change detector), and
    the outputs of the interval and the detector (``HalfWidthUm``, ``Trusted``,
    ``Changes``, ``ChangeKind``, ``ChangeStartS``, ``Innovation``); '' and '' without one."""
    if p.trust is None:
        return "", ""
    t = p.trust
    tolerance = "TRUE" if p.tolerance_um is None else f"HalfWidthUm <= {literal(p.tolerance_um)}"
    return Template(
        r"""glrEmpty := FALSE;
observeEdge := Observe AND NOT observeBefore;
observeBefore := Observe;
recalibrateEdge := Recalibrate AND NOT recalibrateBefore;
recalibrateBefore := Recalibrate;
IF observeEdge THEN
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
        (* everything below works on copies: the state changes only once all is finite *)
        FOR k := 0 TO 2 * WINDOW * 3 - 1 DO
            gD[k] := st_glr_d[k];
        END_FOR;
        FOR k := 0 TO 2 * WINDOW - 1 DO
            gA[k] := st_glr_a[k];
            gB[k] := st_glr_b[k];
        END_FOR;
        FOR k := 0 TO WINDOW - 1 DO
            gT0[k] := st_glr_t0[k];
        END_FOR;
        gN := st_glr_n;
        ckNew := st_change_kind;
        csNew := st_change_start_s;
        chNew := st_changes;
        prevTime := st_ft0;
        propTime := ProbeTimeS;
${propagate}
        IF NOT st_adjusted THEN
            (* the first reading: the batch variance there, all in the offset *)
            FOR k := 0 TO 2 DO
                fx[k] := 0.0;
            END_FOR;
            FOR k := 0 TO 8 DO
                fp[k] := st_fp[k]; (* open only where Recalibrate opened it *)
            END_FOR;
            fp[0] := SCALE * (${offset_var} + ${growth_var} * dh);
        END_IF;
        (* the Kalman update, H = (1, 1, 0), Joseph form *)
        innov := (ProbeUm - m) - (fx[0] + fx[1]);
        FOR k := 0 TO 2 DO
            ph[k] := fp[3 * k] + fp[3 * k + 1];
        END_FOR;
        sv := (ph[0] + ph[1]) + READING_VAR;
        IF sv <= 0.0 THEN
            sv := 2.2250738585072014E-308; (* no uncertainty at all: the reading is the truth *)
        END_IF;
        h[0] := 1.0;
        h[1] := 1.0;
        h[2] := 0.0;
        FOR k := 0 TO 2 DO
            kg[k] := ph[k] / sv;
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
                pn[3 * k + j] := am[3 * k] * ikh[3 * j] + am[3 * k + 1] * ikh[3 * j + 1]
                    + am[3 * k + 2] * ikh[3 * j + 2] + kg[k] * kg[j] * READING_VAR;
            END_FOR;
        END_FOR;
        FOR k := 0 TO 2 DO
            fx[k] := fx[k] + kg[k] * innov;
            FOR j := 0 TO 2 DO
                fp[3 * k + j] := 0.5 * (pn[3 * k + j] + pn[3 * j + k]);
            END_FOR;
        END_FOR;
        (* the change detector (Willsky and Jones, 1976): the bank moves on by one onset *)
        FOR j := 0 TO WINDOW - 2 DO
            jt := WINDOW - 1 - j;
            jf := WINDOW - 2 - j;
            gT0[jt] := gT0[jf];
            FOR c := 0 TO 1 DO
                gA[c * WINDOW + jt] := gA[c * WINDOW + jf];
                gB[c * WINDOW + jt] := gB[c * WINDOW + jf];
                FOR i := 0 TO 2 DO
                    gD[(c * WINDOW + jt) * 3 + i] := gD[(c * WINDOW + jf) * 3 + i];
                END_FOR;
            END_FOR;
        END_FOR;
        gT0[0] := prevTime / 3600.0;
        FOR c := 0 TO 1 DO
            gA[c * WINDOW] := 0.0;
            gB[c * WINDOW] := 0.0;
            FOR i := 0 TO 2 DO
                gD[c * WINDOW * 3 + i] := 0.0;
            END_FOR;
        END_FOR;
        IF gN < WINDOW THEN
            gN := gN + 1;
        END_IF;
        best := 0.0;
        glrKind := 0;
        glrSlot := 0;
        FOR c := 0 TO 1 DO
            FOR j := 0 TO WINDOW - 1 DO
                IF j < gN THEN
                    gi := (c * WINDOW + j) * 3;
                    FOR i := 0 TO 2 DO
                        dd[i] := gD[gi] * ff[3 * i] + gD[gi + 1] * ff[3 * i + 1]
                            + gD[gi + 2] * ff[3 * i + 2];
                    END_FOR;
                    IF c = 0 THEN
                        gg := 1.0;
                    ELSE
                        gg := ProbeTimeS / 3600.0 - gT0[j];
                    END_IF;
                    rho := (0.0 - dd[0]) + (gg - dd[1]);
                    FOR i := 0 TO 2 DO
                        gD[gi + i] := dd[i] + rho * kg[i];
                    END_FOR;
                    gA[c * WINDOW + j] := gA[c * WINDOW + j] + rho * innov / sv;
                    gB[c * WINDOW + j] := gB[c * WINDOW + j] + rho * rho / sv;
                    stat := 0.0;
                    IF gB[c * WINDOW + j] > 0.0 AND (c = 0 OR j > 0) THEN
                        (* a ramp read once is the step: its statistic is the step's *)
                        stat := gA[c * WINDOW + j] * gA[c * WINDOW + j]
                            / gB[c * WINDOW + j];
                    END_IF;
                    IF (c = 0 AND j = 0) OR stat > best THEN
                        best := stat;
                        glrKind := c;
                        glrSlot := j;
                    END_IF;
                END_IF;
            END_FOR;
        END_FOR;
        IF best > GLR_THRESHOLD THEN
            (* a change: its estimate added to the states, its variance to theirs *)
            gi := (glrKind * WINDOW + glrSlot) * 3;
            bb := gB[glrKind * WINDOW + glrSlot];
            sz := gA[glrKind * WINDOW + glrSlot] / bb;
            miss[0] := 0.0 - gD[gi];
            IF glrKind = 0 THEN
                miss[1] := 1.0 - gD[gi + 1];
                miss[2] := 0.0 - gD[gi + 2];
            ELSE
                miss[1] := (ProbeTimeS / 3600.0 - gT0[glrSlot]) - gD[gi + 1];
                miss[2] := 1.0 - gD[gi + 2];
            END_IF;
            FOR k := 0 TO 2 DO
                fx[k] := fx[k] + sz * miss[k];
                FOR j := 0 TO 2 DO
                    fp[3 * k + j] := fp[3 * k + j] + miss[k] * miss[j] / bb;
                END_FOR;
            END_FOR;
            (* a few readings cannot tell a step from a ramp: the bias and the rate
               are opened by the size found (its effect here, and per hour since) *)
            span := ProbeTimeS / 3600.0 - gT0[glrSlot];
            IF span < 1.0E-9 THEN
                span := 1.0E-9;
            END_IF;
            IF glrKind = 0 THEN
                effect2 := sz * sz;
            ELSE
                effect2 := (sz * span) * (sz * span);
            END_IF;
            fp[4] := fp[4] + effect2;
            fp[8] := fp[8] + effect2 / (span * span);
            ckNew := glrKind + 1;
            csNew := gT0[glrSlot] * 3600.0;
            chNew := chNew + 1;
            FOR k := 0 TO 2 * WINDOW * 3 - 1 DO
                gD[k] := 0.0;
            END_FOR;
            FOR k := 0 TO 2 * WINDOW - 1 DO
                gA[k] := 0.0;
                gB[k] := 0.0;
            END_FOR;
            FOR k := 0 TO WINDOW - 1 DO
                gT0[k] := 0.0;
            END_FOR;
            gN := 0;
        END_IF;
        FOR k := 0 TO 2 DO
            FOR j := 0 TO 2 DO
                pn[3 * k + j] := 0.5 * (fp[3 * k + j] + fp[3 * j + k]);
            END_FOR;
        END_FOR;
        stdInnov := innov / SQRT(sv);
        dh := (st_time_s - ProbeTimeS) / 3600.0;
        corrNew := st_model_um + fx[0] * EXP(-dh / MEMORY_H) + fx[1] + fx[2] * dh;
        (* a reading that overflows the filter is refused: nothing changes *)
        ok := ${finite_std} AND ${finite_corr};
        FOR k := 0 TO 2 DO
            ok := ok AND ${finite_fx};
        END_FOR;
        FOR k := 0 TO 8 DO
            ok := ok AND ${finite_pn};
        END_FOR;
        FOR k := 0 TO 2 * WINDOW * 3 - 1 DO
            ok := ok AND ${finite_gd};
        END_FOR;
        FOR k := 0 TO 2 * WINDOW - 1 DO
            ok := ok AND ${finite_ga} AND ${finite_gb};
        END_FOR;
        IF NOT ok THEN
            ProbeStatus := ERR_READING;
        ELSE
            FOR k := 0 TO 2 DO
                st_fx[k] := fx[k];
            END_FOR;
            FOR k := 0 TO 8 DO
                st_fp[k] := pn[k];
            END_FOR;
            FOR k := 0 TO 2 * WINDOW * 3 - 1 DO
                st_glr_d[k] := gD[k];
            END_FOR;
            FOR k := 0 TO 2 * WINDOW - 1 DO
                st_glr_a[k] := gA[k];
                st_glr_b[k] := gB[k];
            END_FOR;
            FOR k := 0 TO WINDOW - 1 DO
                st_glr_t0[k] := gT0[k];
            END_FOR;
            st_glr_n := gN;
            st_change_kind := ckNew;
            st_change_start_s := csNew;
            st_changes := chNew;
            st_ft0 := ProbeTimeS;
            st_has_ft0 := TRUE;
            st_adjusted := TRUE;
            st_has_reading := TRUE;
            st_last_reading := ProbeTimeS;
            st_innovation := stdInnov;
            st_correction_um := corrNew;
        END_IF;
    END_IF;
END_IF;
IF recalibrateEdge THEN
    (* a known change: the bias and its rate become uncertain *)
    recalSize := SQRT(${offset_var} + ${noise_var});
    IF recalSize = 0.0 THEN
        recalSize := 1.0;
    END_IF;
    IF ${finite_recal4} AND ${finite_recal8} THEN
        st_fp[4] := st_fp[4] + recalSize * recalSize;
        st_fp[8] := st_fp[8] + recalSize * recalSize;
        st_changes := st_changes + 1;
        glrEmpty := TRUE;
    END_IF;
END_IF;
IF glrEmpty THEN
    (* the change detector's bank emptied: after a change found, or Recalibrate *)
    FOR j := 0 TO WINDOW - 1 DO
        st_glr_t0[j] := 0.0;
        FOR c := 0 TO 1 DO
            st_glr_a[c * WINDOW + j] := 0.0;
            st_glr_b[c * WINDOW + j] := 0.0;
            FOR i := 0 TO 2 DO
                st_glr_d[(c * WINDOW + j) * 3 + i] := 0.0;
            END_FOR;
        END_FOR;
    END_FOR;
    st_glr_n := 0;
END_IF;
"""
    ).substitute(
        finite_probe_time=finite("ProbeTimeS"),
        finite_probe=finite("ProbeUm"),
        finite_std=finite("stdInnov"),
        finite_corr=finite("corrNew"),
        finite_fx=finite("fx[k]"),
        finite_pn=finite("pn[k]"),
        finite_gd=finite("gD[k]"),
        finite_ga=finite("gA[k]"),
        finite_gb=finite("gB[k]"),
        finite_recal4=finite("st_fp[4] + recalSize * recalSize"),
        finite_recal8=finite("st_fp[8] + recalSize * recalSize"),
        max_correction=literal(p.max_correction_um),
        offset_var=literal(t.offset_var),
        growth_var=literal(t.growth_var_per_h),
        noise_var=literal(t.noise_var),
        propagate=_propagate_st("        "),
    ), _status_st(p, tolerance)


def _propagate_st(indent):
    """fx, fp := the filter carried from its time to propTime (F x, F P F' + Q; F in ff)."""
    lines = """dh := (propTime - st_ft0) / 3600.0;
IF dh < 0.0 THEN
    dh := 0.0;
END_IF;
phi := EXP(-dh / MEMORY_H);
ff[0] := phi; ff[1] := 0.0; ff[2] := 0.0;
ff[3] := 0.0; ff[4] := 1.0; ff[5] := dh;
ff[6] := 0.0; ff[7] := 0.0; ff[8] := 1.0;
FOR k := 0 TO 8 DO
    qq[k] := 0.0;
END_FOR;
qq[0] := SCALE * (MEMORY_VAR * (1.0 - phi * phi));
qq[4] := SCALE * (BIAS_VAR * dh + RATE_VAR * EXPT(dh, 3.0) / 3.0);
qq[5] := SCALE * (RATE_VAR * dh * dh / 2.0);
qq[7] := qq[5];
qq[8] := SCALE * (RATE_VAR * dh);
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
            + am[3 * k + 2] * ff[3 * j + 2] + qq[3 * k + j];
    END_FOR;
END_FOR;"""
    return "\n".join(indent + line for line in lines.split("\n"))


def _status_st(p, tolerance):
    """HalfWidthUm, Trusted, Changes and what the change detector found, at every call."""
    t = p.trust
    return Template(
        r"""HalfWidthUm := 0.0;
Trusted := FALSE;
IF st_started THEN
    dh := (st_time_s - st_ft0) / 3600.0;
    IF dh < 0.0 THEN
        dh := 0.0;
    END_IF;
    IF NOT st_adjusted THEN
        variance := ${offset_var} + ${growth_var} * dh + ${noise_var};
    ELSE
        (* H (F P F' + Q) H' with H F = (phi, 1, dh), in scalars, as Python computes it *)
        phi := EXP(-dh / MEMORY_H);
        hph := phi * phi * st_fp[0] + st_fp[4] + dh * dh * st_fp[8]
            + 2.0 * (phi * st_fp[1] + phi * dh * st_fp[2] + dh * st_fp[5]);
        hqh := MEMORY_VAR * (1.0 - phi * phi) + BIAS_VAR * dh;
        hqh := hqh + RATE_VAR * EXPT(dh, 3.0) / 3.0;
        variance := hph + SCALE * hqh;
        IF variance < 0.0 THEN
            variance := 0.0;
        ELSIF NOT (variance >= 0.0) THEN
            variance := 1.7976931348623157E308; (* inf - inf: nothing is known *)
        END_IF;
        variance := variance + WHITE_VAR;
    END_IF;
    HalfWidthUm := ${quantile} * SQRT(variance)${widening};
    Trusted := Plausible AND ${tolerance};
END_IF;
Changes := st_changes;
ChangeKind := st_change_kind;
ChangeStartS := st_change_start_s;
Innovation := st_innovation;
"""
    ).substitute(
        offset_var=literal(t.offset_var),
        growth_var=literal(t.growth_var_per_h),
        noise_var=literal(t.noise_var),
        quantile=literal(t.interval_quantile),
        tolerance=tolerance,
        widening="" if p.envelope is None else " + st_widening_um",
    )


# -- the function block ----------------------------------------------------------

_TYPES = {"real": "LREAL", "int": "DINT", "bool": "BOOL"}


def _list(values, fmt, per_line=4):
    items = [fmt(v) for v in values] or [fmt(0)]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return "[\n        " + ",\n        ".join(lines) + "\n    ]"


def _bool(v):
    return "TRUE" if v else "FALSE"


def _state_declarations(p):
    lines = []
    for v in p.state:
        kind = _TYPES[v.kind]
        if v.length > 1 or v.name in ARRAYS:
            kind = f"ARRAY[0..{max(v.length, 1) - 1}] OF {kind}"
        unit = f" ({v.unit})" if v.unit else ""
        lines.append(f"    st_{v.name} : {kind}; (* {v.meaning}{unit} *)")
    return "\n".join(lines)


def _reset_body(p):
    """Every state variable back to 0, but the output (what the axis has)."""
    zero = {"real": "0.0", "int": "0", "bool": "FALSE"}
    lines = []
    for v in p.state:
        if v.name in ("output_um", "last"):
            continue
        if v.length > 1 or v.name in ARRAYS:
            lines += [
                f"    FOR k := 0 TO {max(v.length, 1) - 1} DO",
                f"        st_{v.name}[k] := {zero[v.kind]};",
                "    END_FOR;",
            ]
        else:
            lines.append(f"    st_{v.name} := {zero[v.kind]};")
    lines += [
        "    st_has_initial := UseInitial;",
        "    IF UseInitial THEN",
        "        st_initial := InitialUm;",
        "    END_IF;",
    ]
    return "\n".join(lines)


def _stage_st(p):
    """Step (7): the output stage (:func:`greyml.controller._output.limit_output`)."""
    lines = []
    if p.clamp_um is not None:
        c = literal(p.clamp_um)
        lines += [
            f"        IF value > {c} THEN",
            f"            value := {c};",
            f"        ELSIF value < -{c} THEN",
            f"            value := -{c};",
            "        END_IF;",
        ]
    rate = None if p.rate_limit_um_s is None else literal(p.rate_limit_um_s)
    if p.quantum_um is None:
        if rate is not None:
            lines += [
                "        allowed := 0.0;",
                "        IF hasDt THEN",
                f"            allowed := {rate} * dt;",
                "        END_IF;",
                "        IF value < st_last - allowed THEN",
                "            value := st_last - allowed;",
                "        END_IF;",
                "        IF value > st_last + allowed THEN",
                "            value := st_last + allowed;",
                "        END_IF;",
            ]
        lines += ["        st_last := value;", "        st_output_um := value;"]
        return "\n".join(lines)
    q = literal(p.quantum_um)
    lines += [
        "        (* whole quanta, halves away from zero; TRUNC of a number >= 0 is its floor *)",
        f"        m := ABS(value) / {q} + 0.5;",
        f"        IF m > {literal(QUANTA_MAX)} THEN",
        f"            m := {literal(QUANTA_MAX)};",
        "        END_IF;",
        "        count := DINT_TO_LREAL(TRUNC(m));",
        "        IF value < 0.0 THEN",
        "            count := -count;",
        "        END_IF;",
    ]
    if rate is not None:
        lines += [
            "        IF hasDt THEN",
            f"            cap := {rate} * dt;",
            f"            IF cap < {q} THEN",
            f"                cap := {q};",
            "            END_IF;",
            f"            st_credit_um := st_credit_um + {rate} * dt;",
            "            IF st_credit_um > cap THEN",
            "                st_credit_um := cap;",
            "            END_IF;",
            "        END_IF;",
            "        d := count - st_last;",
            "        m := ABS(d);",
            f"        allowed := st_credit_um / {q} + {literal(QUANTUM_TOLERANCE)};",
            "        IF allowed < m THEN",
            "            m := allowed;",
            "        END_IF;",
            "        m := DINT_TO_LREAL(TRUNC(m));",
            "        IF d > 0.0 THEN",
            "            count := st_last + m;",
            "        ELSE",
            "            count := st_last - m;",
            "        END_IF;",
            f"        st_credit_um := st_credit_um - m * {q};",
            "        IF st_credit_um < 0.0 THEN",
            "            st_credit_um := 0.0;",
            "        END_IF;",
        ]
    lines += ["        st_last := count;", f"        st_output_um := count * {q};"]
    return "\n".join(lines)


def _indent(text, by="    "):
    return "\n".join(by + line if line else line for line in text.split("\n"))


def _record_st(p):
    """Step (6): the probe filter's record of the row, or the model's correction as it is."""
    if p.trust is None:
        return "        st_model_um := modelNew;\n        st_correction_um := value;"
    return """        IF shift <> 0.0 THEN
            (* the rows' clock restarted (a new piece): move the filter's times with it *)
            IF st_has_ft0 THEN
                st_ft0 := st_ft0 - shift;
            END_IF;
            IF st_has_reading THEN
                st_last_reading := st_last_reading - shift;
            END_IF;
            FOR k := 0 TO HISTORY - 1 DO
                st_ht[k] := st_ht[k] - shift;
            END_FOR;
            FOR k := 0 TO WINDOW - 1 DO
                IF k < st_glr_n THEN
                    st_glr_t0[k] := st_glr_t0[k] - shift / 3600.0;
                END_IF;
            END_FOR;
            IF st_change_kind <> 0 THEN
                st_change_start_s := st_change_start_s - shift;
            END_IF;
        END_IF;
        IF NOT st_has_ft0 THEN
            st_ft0 := TimeS;
            st_has_ft0 := TRUE;
        END_IF;
        st_ht[st_hpos] := TimeS;
        st_hm[st_hpos] := modelNew;
        st_hpos := (st_hpos + 1) MOD HISTORY;
        IF st_hcount < HISTORY THEN
            st_hcount := st_hcount + 1;
        END_IF;
        st_model_um := modelNew;
        st_correction_um := value;"""


_BODY = Template(
    r"""
(* what a call does: Reset, then Execute (a row), then Observe and Recalibrate, each on
   its rising edge (FALSE at the previous call, TRUE at this one) *)
executeEdge := Execute AND NOT executeBefore;
executeBefore := Execute;
resetEdge := Reset AND NOT resetBefore;
resetBefore := Reset;
missing := NOT InputsValid;
${copy_inputs}
FOR j := 0 TO N_INPUTS - 1 DO
    IF NOT ${finite_xin} THEN
        missing := TRUE;
    END_IF;
END_FOR;
IF resetEdge THEN
${reset}
END_IF;
IF executeEdge THEN
    code := 0;
    refuse := FALSE;
    hasDt := FALSE;
    dt := 0.0;
    shift := 0.0;
    total := 0.0;
    (* (1) a negative input to a fractional power (a missing input is never negative) *)
    FOR k := 0 TO N_TERMS - 1 DO
        IF FRACTIONAL[k] AND InputsValid AND xin[INPUT[k]] < 0.0 THEN
            refuse := TRUE;
        END_IF;
    END_FOR;
    (* (2) the time *)
    IF NOT refuse THEN
        IF NOT ${finite_time} THEN
            code := ERR_TIME;
        ELSIF st_started THEN
            hasDt := TRUE;
            dt := TimeS - st_time_s;
            IF NOT (dt > 0.0) THEN
${restart}${gap}
            END_IF;
        END_IF;
    END_IF;
    (* (3) every input finite *)
    IF NOT refuse AND code = 0 AND missing THEN
        refuse := TRUE;
    END_IF;
    (* (4) the lags and their weighted sum *)
    IF NOT refuse AND code = 0 THEN
        FOR k := 0 TO N_TERMS - 1 DO
            IF POWER[k] = 1.0 THEN
                v[k] := xin[INPUT[k]];
            ELSE
                v[k] := EXPT(xin[INPUT[k]], POWER[k]);
            END_IF;
            IF NOT st_started THEN
                lagNew[k] := v[k];
                IF k < N_LAGS THEN
                    IF IDLE[k] THEN
                        lagNew[k] := 0.0;
                    END_IF;
                END_IF;
            ELSIF k < N_LAGS THEN
                a := EXP(-dt / TAU[k]);
                lagNew[k] := (1.0 - a) * v[k] + a * st_lag[k];
            ELSE
                lagNew[k] := v[k];
            END_IF;
            total := total + WEIGHT[k] * lagNew[k];
        END_FOR;
        IF NOT ${finite_total} THEN
            refuse := TRUE;
        END_IF;
    END_IF;${env_step}
    IF refuse THEN
        IF NOT ${finite_time} THEN
            code := ERR_TIME;
        ELSIF missing THEN
${missing}
        ELSE
            code := ERR_VALUE;
        END_IF;
    ELSIF code = 0 THEN
        (* (5) the reference and (6) the correction, probe filter included: refused if
           not finite or beyond max_correction_um, before anything is kept *)
        hasStartNew := st_has_start;
        startNew := st_start;
        IF NOT st_started THEN
            IF st_has_initial THEN
                hasStartNew := TRUE;
                startNew := ${intercept} + total - st_initial;
            ELSE
                hasStartNew := ${relative};
                startNew := 0.0;
                IF ${relative} THEN
                    startNew := total;
                END_IF;
            END_IF;
        END_IF;
        IF hasStartNew THEN
            total := total - startNew;
        END_IF;
        modelNew := ${intercept} + total;
        value := modelNew;${filter_value}
        IF NOT (ABS(value) <= ${max_correction}) THEN
            code := ERR_VALUE;
        ELSE
            st_has_start := hasStartNew;
            st_start := startNew;
            FOR k := 0 TO N_TERMS - 1 DO
                st_lag[k] := lagNew[k];
            END_FOR;${env_store}
${record}
            st_started := TRUE;
            st_time_s := TimeS;
            st_held := FALSE;
            (* (7) the output stage *)
${stage}
        END_IF;
    END_IF;
    Status := code;
END_IF;
${observe}
OutputUm := st_output_um;
CorrectionUm := st_correction_um;
Held := st_held;
Started := st_started;
Plausible := st_started AND ABS(st_correction_um) <= ${max_correction};${env_outputs}
${status_outputs}
"""
)


def _envelope_st(p):
    """The envelope's step and store (Execute) and its outputs, or '' each."""
    if p.envelope is None:
        return {"env_step": "", "env_store": "", "env_outputs": ""}
    step = r"""
    (* (4b) the envelope: each enveloped input's follower, and the excess bank *)
    IF NOT refuse AND code = 0 THEN
        outsideNew := 0;
        FOR j := 0 TO N_INPUTS - 1 DO
            xt[j] := xin[j];
        END_FOR;
        FOR j := 0 TO N_ENV - 1 DO
            fi := xin[ENV_INPUT[j]];
            lo := ENV_LOW[j];
            hi := ENV_HIGH[j];
            IF st_started THEN
                reach := ENV_RATE[j] * (dt / 3600.0) * (1.0 + RATE_SLACK);
                IF st_ef[j] - reach >= lo THEN
                    lo := st_ef[j] - reach;
                END_IF;
                IF st_ef[j] + reach <= hi THEN
                    hi := st_ef[j] + reach;
                END_IF;
            END_IF;
            IF fi < lo THEN
                fi := lo;
            END_IF;
            IF fi > hi THEN
                fi := hi;
            END_IF;
            efNew[j] := fi;
            exNew[j] := xin[ENV_INPUT[j]] - fi;
            xt[ENV_INPUT[j]] := fi;
            IF outsideNew = 0 AND exNew[j] <> 0.0 THEN
                outsideNew := ENV_INPUT[j] + 1;
            END_IF;
        END_FOR;
        FOR j := 0 TO N_ENV - 1 DO
            din[j] := 0.0;
        END_FOR;
        FOR k := 0 TO N_TERMS - 1 DO
            IF POWER[k] = 1.0 THEN
                w := xt[INPUT[k]];
            ELSE
                w := EXPT(xt[INPUT[k]], POWER[k]);
            END_IF;
            e := v[k] - w;
            IF NOT st_started THEN
                elagNew[k] := e;
                IF k < N_LAGS THEN
                    IF IDLE[k] THEN
                        elagNew[k] := 0.0;
                    END_IF;
                END_IF;
            ELSIF k < N_LAGS THEN
                a := EXP(-dt / TAU[k]);
                elagNew[k] := (1.0 - a) * e + a * st_elag[k];
            ELSE
                elagNew[k] := e;
            END_IF;
            IF ENV_SLOT[k] >= 0 THEN
                din[ENV_SLOT[k]] := din[ENV_SLOT[k]] + WEIGHT[k] * elagNew[k];
            END_IF;
        END_FOR;
    END_IF;"""
    store = r"""
        (* the envelope's state; the half-width widens by the model's response to the excess *)
        IF NOT st_started THEN
            st_has_estart := st_has_start;
        END_IF;
        st_widening_um := 0.0;
        FOR j := 0 TO N_ENV - 1 DO
            IF NOT st_started THEN
                st_estart[j] := 0.0;
                IF st_has_start THEN
                    st_estart[j] := din[j];
                END_IF;
            END_IF;
            IF st_has_estart THEN
                st_widening_um := st_widening_um + ABS(din[j] - st_estart[j]);
            ELSE
                st_widening_um := st_widening_um + ABS(din[j]);
            END_IF;
            st_ef[j] := efNew[j];
            st_ex[j] := exNew[j];
        END_FOR;
        FOR k := 0 TO N_TERMS - 1 DO
            st_elag[k] := elagNew[k];
        END_FOR;
        st_outside := outsideNew;"""
    outputs = "\nOutside := st_outside;\nWideningUm := st_widening_um;"
    return {"env_step": step, "env_store": _indent(store), "env_outputs": outputs}


def _declarations(p):
    """The function block's interface, state, scratch variables and constants."""
    n_terms, n_lags, n_inputs = len(p.terms), p.n_lags, len(p.inputs)
    trust = p.trust is not None
    inputs = [
        "    Execute : BOOL; (* rising edge: take the row of TimeS and the inputs below *)",
        "    TimeS : LREAL; (* the row's time, s *)",
    ]
    for v in p.inputs:
        inputs.append(f"    {v.identifier} : LREAL; (* {v.comment}, {v.unit} *)")
    inputs += [
        "    InputsValid : BOOL := TRUE; (* FALSE: an input is missing, as a NaN would be *)",
        "    Reset : BOOL; (* rising edge: forget the state first; the output is kept *)",
        "    UseInitial : BOOL; (* with Reset: the displacement at the next row is InitialUm *)",
        "    InitialUm : LREAL; (* um *)",
    ]
    if trust:
        inputs += [
            "    Observe : BOOL; (* rising edge: take the probe reading (after the row, if any) *)",
            "    ProbeTimeS : LREAL; (* when it was measured, s, on the rows' clock *)",
            "    ProbeUm : LREAL; (* the measured displacement, um *)",
            "    Recalibrate : BOOL; (* rising edge: let readings estimate a step and drift *)",
        ]
    outputs = [
        "    OutputUm : LREAL; (* the predicted displacement after the limits, um *)",
        "    CorrectionUm : LREAL; (* the predicted displacement before the limits, um *)",
        "    Status : DINT; (* of the last row: 0 taken, 1 held, < 0 refused *)",
        "    Held : BOOL; (* the last row had a missing input: OutputUm is the one before *)",
        "    Started : BOOL; (* a row was taken since the start or Reset *)",
        "    Plausible : BOOL; (* CorrectionUm within max_correction_um *)",
    ]
    env = p.envelope
    if env is not None:
        outputs += [
            "    Outside : DINT; (* 0 inside the envelope, else 1 + the first input outside *)",
            "    WideningUm : LREAL; (* what the half-width adds for the excess, um *)",
        ]
    if trust:
        outputs += [
            "    ProbeStatus : DINT; (* of the last reading: 0 taken, -4 refused *)",
            "    HalfWidthUm : LREAL; (* of the interval at the last row, um (0 before one) *)",
            "    Trusted : BOOL; (* plausible, and HalfWidthUm within tolerance_um *)",
            "    Changes : DINT; (* how many times the change detector fired or Recalibrate *)",
            "    ChangeKind : DINT; (* the last change found: 0 none, 1 step, 2 ramp *)",
            "    ChangeStartS : LREAL; (* when it began, s on the rows' clock (0 before one) *)",
            "    Innovation : LREAL; (* the last reading's standardised innovation (0 before) *)",
        ]
    scratch = [
        f"    xin : ARRAY[0..{n_inputs - 1 if n_inputs else 0}] OF LREAL;",
        f"    v : ARRAY[0..{max(n_terms, 1) - 1}] OF LREAL;",
        f"    lagNew : ARRAY[0..{max(n_terms, 1) - 1}] OF LREAL;",
        "    k : DINT;",
        "    j : DINT;",
        "    code : DINT;",
        "    refuse : BOOL;",
        "    missing : BOOL;",
        "    hasDt : BOOL;",
        "    dt : LREAL;",
        "    shift : LREAL;",
        "    total : LREAL;",
        "    value : LREAL;",
        "    a : LREAL;",
        "    m : LREAL;",
        "    count : LREAL;",
        "    cap : LREAL;",
        "    d : LREAL;",
        "    allowed : LREAL;",
        "    hasStartNew : BOOL;",
        "    startNew : LREAL;",
        "    modelNew : LREAL;",
        "    executeEdge : BOOL; (* Execute rose since the previous call *)",
        "    executeBefore : BOOL; (* Execute at the previous call *)",
        "    resetEdge : BOOL;",
        "    resetBefore : BOOL;",
    ]
    if env is not None:
        n_env = len(env.input)
        scratch += [
            f"    xt : ARRAY[0..{n_inputs - 1 if n_inputs else 0}] OF LREAL;",
            f"    efNew : ARRAY[0..{n_env - 1}] OF LREAL;",
            f"    exNew : ARRAY[0..{n_env - 1}] OF LREAL;",
            f"    elagNew : ARRAY[0..{max(n_terms, 1) - 1}] OF LREAL;",
            f"    din : ARRAY[0..{n_env - 1}] OF LREAL;",
            "    outsideNew : DINT;",
            "    fi : LREAL;",
            "    lo : LREAL;",
            "    hi : LREAL;",
            "    reach : LREAL;",
            "    w : LREAL;",
            "    e : LREAL;",
        ]
    if trust:
        scratch += [
            "    dh : LREAL;",
            "    phi : LREAL;",
            "    propTime : LREAL;",
            "    oldest : DINT;",
            "    j0 : DINT;",
            "    j1 : DINT;",
            "    found : BOOL;",
            "    slope : LREAL;",
            "    innov : LREAL;",
            "    hph : LREAL;",
            "    hqh : LREAL;",
            "    sv : LREAL;",
            "    variance : LREAL;",
            "    recalSize : LREAL;",
            "    prevTime : LREAL;",
            "    i : DINT;",
            "    c : DINT;",
            "    jt : DINT;",
            "    jf : DINT;",
            "    gi : DINT;",
            "    glrKind : DINT;",
            "    glrSlot : DINT;",
            "    best : LREAL;",
            "    stat : LREAL;",
            "    gg : LREAL;",
            "    rho : LREAL;",
            "    bb : LREAL;",
            "    sz : LREAL;",
            "    span : LREAL;",
            "    effect2 : LREAL;",
            "    glrEmpty : BOOL;",
            "    observeEdge : BOOL;",
            "    observeBefore : BOOL;",
            "    recalibrateEdge : BOOL;",
            "    recalibrateBefore : BOOL;",
            "    ok : BOOL;",
            "    gN : DINT;",
            "    ckNew : DINT;",
            "    chNew : DINT;",
            "    csNew : LREAL;",
            "    stdInnov : LREAL;",
            "    corrNew : LREAL;",
            f"    gD : ARRAY[0..{2 * p.trust.window * 3 - 1}] OF LREAL;",
            f"    gA : ARRAY[0..{2 * p.trust.window - 1}] OF LREAL;",
            f"    gB : ARRAY[0..{2 * p.trust.window - 1}] OF LREAL;",
            f"    gT0 : ARRAY[0..{p.trust.window - 1}] OF LREAL;",
            "    fx : ARRAY[0..2] OF LREAL;",
            "    dd : ARRAY[0..2] OF LREAL;",
            "    miss : ARRAY[0..2] OF LREAL;",
            "    qq : ARRAY[0..8] OF LREAL;",
            "    h : ARRAY[0..2] OF LREAL;",
            "    ph : ARRAY[0..2] OF LREAL;",
            "    kg : ARRAY[0..2] OF LREAL;",
            "    fp : ARRAY[0..8] OF LREAL;",
            "    ff : ARRAY[0..8] OF LREAL;",
            "    ikh : ARRAY[0..8] OF LREAL;",
            "    am : ARRAY[0..8] OF LREAL;",
            "    pn : ARRAY[0..8] OF LREAL;",
        ]
    terms = p.terms
    lags = terms[:n_lags]
    constants = [
        f"    N_INPUTS : DINT := {n_inputs};",
        f"    N_TERMS : DINT := {n_terms};",
        f"    N_LAGS : DINT := {n_lags};",
        *(f"    {key} : DINT := {code};" for key, (code, _) in STATUS_CODES.items() if code < 0),
        f"    INPUT : ARRAY[0..{max(n_terms, 1) - 1}] OF DINT := "
        + _list([t.input for t in terms], str, 16)
        + ";",
        f"    POWER : ARRAY[0..{max(n_terms, 1) - 1}] OF LREAL := "
        + _list([t.power for t in terms], literal)
        + ";",
        f"    FRACTIONAL : ARRAY[0..{max(n_terms, 1) - 1}] OF BOOL := "
        + _list([t.fractional for t in terms], _bool, 8)
        + ";",
        f"    WEIGHT : ARRAY[0..{max(n_terms, 1) - 1}] OF LREAL := "
        + _list([t.weight for t in terms], literal)
        + ";",
        f"    TAU : ARRAY[0..{max(n_lags, 1) - 1}] OF LREAL := "
        + _list([t.tau_s for t in lags] or [1.0], literal)
        + ";",
        f"    IDLE : ARRAY[0..{max(n_lags, 1) - 1}] OF BOOL := "
        + _list([t.idle for t in lags], _bool, 8)
        + ";",
    ]
    if env is not None:
        n_env = len(env.input)
        constants += [
            f"    N_ENV : DINT := {n_env};",
            f"    RATE_SLACK : LREAL := {literal(env.rate_slack)};",
            f"    ENV_INPUT : ARRAY[0..{n_env - 1}] OF DINT := {_list(env.input, str, 16)};",
            f"    ENV_LOW : ARRAY[0..{n_env - 1}] OF LREAL := {_list(env.low, literal)};",
            f"    ENV_HIGH : ARRAY[0..{n_env - 1}] OF LREAL := {_list(env.high, literal)};",
            f"    ENV_RATE : ARRAY[0..{n_env - 1}] OF LREAL := "
            + _list(env.max_rate_per_h, literal)
            + ";",
            f"    ENV_SLOT : ARRAY[0..{max(n_terms, 1) - 1}] OF DINT := "
            + _list(env.term_slot, str, 16)
            + ";",
        ]
    if trust:
        constants += [
            f"    HISTORY : DINT := {p.trust.history};",
            f"    MEMORY_H : LREAL := {literal(p.trust.memory_h)};",
            f"    MEMORY_VAR : LREAL := {literal(p.trust.memory_var)};",
            f"    WINDOW : DINT := {p.trust.window};",
            f"    BIAS_VAR : LREAL := {literal(p.trust.bias_var_per_h)};",
            f"    RATE_VAR : LREAL := {literal(p.trust.rate_var_per_h3)};",
            f"    SCALE : LREAL := {literal(p.trust.scale)};",
            f"    READING_VAR : LREAL := {literal(p.trust.reading_var)};",
            f"    WHITE_VAR : LREAL := {literal(p.trust.white_var)};",
            f"    GLR_THRESHOLD : LREAL := {literal(p.trust.glr_threshold)};",
        ]
    return "\n".join(
        [
            "VAR_INPUT",
            *inputs,
            "END_VAR",
            "VAR_OUTPUT",
            *outputs,
            "END_VAR",
            "VAR",
            _state_declarations(p),
            *scratch,
            "END_VAR",
            "VAR CONSTANT",
            *constants,
            "END_VAR",
        ]
    )


def write_st(p):
    """The Structured Text source of :class:`Program` ``p``, as text."""
    if p.nominal_step_s is None:
        restart = "                code := ERR_TIME;"
    else:
        restart = (
            "                (* the next piece of the recording: its clock starts anew *)\n"
            f"                dt := {literal(p.nominal_step_s)};\n"
            "                shift := st_time_s + dt - TimeS;"
        )
    gap = (
        ""
        if p.max_step_s is None
        else (
            f"\n            ELSIF dt > {literal(p.max_step_s)} THEN\n"
            "                code := ERR_GAP;"
        )
    )
    if p.hold:
        missing = "            st_held := TRUE;\n            code := 1;"
    else:
        missing = "            code := ERR_VALUE;"
    copy = "\n".join(f"xin[{j}] := {v.identifier};" for j, v in enumerate(p.inputs))
    observe, status = observe_block(p)
    body = _BODY.substitute(
        copy_inputs=copy,
        finite_xin=finite("xin[j]"),
        finite_time=finite("TimeS"),
        finite_total=finite("total"),
        reset=_reset_body(p),
        restart=restart,
        gap=gap,
        missing=missing,
        intercept=literal(p.intercept),
        relative=_bool(p.relative_to_start),
        record=_indent(_record_st(p)),
        stage=_indent(_stage_st(p)),
        filter_value=(
            ""
            if p.trust is None
            else "\n        IF st_adjusted THEN\n"
            "            dh := (TimeS - (st_ft0 - shift)) / 3600.0;\n"
            "            value := value + st_fx[0] * EXP(-dh / MEMORY_H) + st_fx[1]\n"
            "                + st_fx[2] * dh;\n"
            "        END_IF;"
        ),
        observe=observe,
        max_correction=literal(p.max_correction_um),
        status_outputs=status,
        **_envelope_st(p),
    )
    call = (
        f"call {p.name} once every PLC cycle (cyclic); a command acts on its rising edge only "
        "(FALSE at the previous call, TRUE at this one, as PLCopen's Execute): Reset, then "
        "Execute (take the row of TimeS and the inputs; time_s must increase), then Observe "
        "and Recalibrate, in that order within one call; a command held TRUE acts once. "
        "OutputUm is the output, held between rows"
    )
    found = (
        "What it found: ChangeKind (0 none, 1 step, 2 ramp), ChangeStartS (when it began, s on "
        "the rows' clock; 0 before one is found), Innovation (the last reading's standardised "
        "innovation; 0 before a reading); Changes counts its firings and Recalibrate."
    )
    lines = wrap(header_lines(p, "IEC 61131-3 Structured Text", call, found))
    header = "(*\n" + "\n".join(f"  {line}".rstrip() for line in lines) + "\n*)\n"
    return (
        header
        + f"FUNCTION_BLOCK {p.name}\n"
        + _declarations(p)
        + "\n"
        + body
        + "END_FUNCTION_BLOCK\n"
    )
