"""A Compensator as one self-contained C99 file, written from its :class:`Program`.

The file declares a state struct and the functions ``<name>_init``,
``<name>_reset``, ``<name>_update`` and (with a calibration) ``<name>_observe``,
``<name>_recalibrate`` and ``<name>_half_width``, with the arithmetic and the
order of checks of :meth:`greyml.dynamic.Compensator.update`. Every loop runs
over a compile-time constant (the terms, the inputs, the 512 rows of the
probe filter's ring), nothing is allocated, and only ``<math.h>`` is used.
"""

from __future__ import annotations

import math
import textwrap
from string import Template

from greyml.controller._export._program import ARRAYS, STATUS_CODES
from greyml.controller._output import QUANTA_MAX, QUANTUM_TOLERANCE

__all__ = ["write_c"]


def _real(x):
    """A double literal that reads back as exactly ``x`` (shortest round trip); an
    infinite bound is ``HUGE_VAL`` of ``<math.h>``."""
    x = float(x)
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "(-HUGE_VAL)"
    if math.isnan(x):
        raise ValueError("Compensator.export: a number to write is NaN.")
    text = repr(x)
    return text if any(c in text for c in ".en") else text + ".0"


def _array(values, fmt=_real, per_line=4):
    items = [fmt(v) for v in values] or ["0"]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return "{\n    " + ",\n    ".join(lines) + "\n}"


def wrap(lines, width=92):
    """``lines`` wrapped to ``width`` (a wrapped line goes on indented)."""
    out = []
    for line in lines:
        out += textwrap.wrap(line, width, subsequent_indent="    ") or [""]
    return out


def _header(p, lines):
    """The header comment: ``lines`` of safe text (see :mod:`_program`) inside ``/* */``."""
    return "/*\n" + "\n".join(f" * {line}".rstrip() for line in wrap(lines)) + "\n */\n"


def header_lines(p, language, call):
    """The header's lines, shared by the C and Structured Text writers."""
    lines = [
        f"{p.name}: a thermal-error compensator exported by greyml {p.greyml_version}",
        f"({language}; Compensator.export). Generated: do not edit by hand.",
        "",
        f"Model: {p.description}.",
        f"Inputs, in this order ({len(p.inputs)}; units as in training):",
    ]
    for j, v in enumerate(p.inputs):
        lines.append(f"  {j:3d}  {v.identifier:<32s} {v.comment} ({v.unit})")
    lines += [
        "Output: the thermal displacement the model predicts, in um (micrometres), after the "
        "limits below; the axis offset that compensates it is usually its negative (greyml "
        "predict writes compensation = -prediction): check the sign on the machine.",
        f"Use: {call}.",
        f"Reference: {p.reference}.",
        f"Time: {p.time_step}.",
        f"Limits: {p.limits_text()}.",
        "Probe readings: "
        + (
            f"observe (Kalman filter, {p.trust.history} rows remembered, change "
            f"threshold {p.trust.change_threshold:g})"
            if p.trust is not None
            else "none (the model has no calibration)"
        )
        + ".",
        *(() if p.envelope is None else p.envelope.lines(p.inputs, "Structured" in language)),
        "Status codes (update, observe):",
        *(f"  {code:2d} {key}: {meaning}." for key, (code, meaning) in STATUS_CODES.items()),
        "Not safety-certified. Validate it on the machine before it moves an axis.",
    ]
    return lines


_KINDS = {"real": "double", "int": "long", "bool": "int"}


def _struct(p):
    members = []
    for v in p.state:
        size = f"[{max(v.length, 1)}]" if v.length > 1 or v.name in ARRAYS else ""
        unit = f" ({v.unit})" if v.unit else ""
        members.append(f"    {_KINDS[v.kind]} {v.name}{size}; /* {v.meaning}{unit} */")
    return "\n".join(members)


_TEMPLATE = Template(
    r"""
#include <math.h>

#define ${M}_N_INPUTS ${n_inputs}
#define ${M}_N_TERMS ${n_terms}
#define ${M}_N_LAGS ${n_lags}${env_macros}
${status_macros}
${input_macros}

typedef struct {
${members}
} ${P}_state;

void ${P}_init(${P}_state *s);
void ${P}_reset(${P}_state *s, int has_initial, double initial_um);
int ${P}_update(${P}_state *s, double time_s, const double x[${M}_N_INPUTS], double *output_um);
int ${P}_plausible(const ${P}_state *s);
${trust_declarations}
static const int ${P}_input[${n_terms_1}] = ${input_index};
static const double ${P}_power[${n_terms_1}] = ${powers};
static const int ${P}_fractional[${n_terms_1}] = ${fractional};
static const double ${P}_weight[${n_terms_1}] = ${weights};
static const double ${P}_tau[${n_lags_1}] = ${taus};
static const int ${P}_idle[${n_lags_1}] = ${idle};${env_tables}

void ${P}_init(${P}_state *s)
{
    ${P}_state zero = {0};
    *s = zero;
}

void ${P}_reset(${P}_state *s, int has_initial, double initial_um)
{
    /* the output, what the axis has, is kept */
    double output = s->output_um, last = s->last;
    ${P}_init(s);
    s->output_um = output;
    s->last = last;
    s->has_initial = has_initial;
    s->initial = has_initial ? initial_um : 0.0;
}

int ${P}_plausible(const ${P}_state *s)
{
    return s->started && fabs(s->correction_um) <= ${max_correction};
}

static int ${P}_refuse(${P}_state *s, double time_s, const double x[])
{
    int j;
    if (!isfinite(time_s)) return ${M}_ERR_TIME;
    for (j = 0; j < ${M}_N_INPUTS; j++) {
        if (!isfinite(x[j])) {
${missing}
        }
    }
    return ${M}_ERR_VALUE;
}
${trust_functions}
int ${P}_update(${P}_state *s, double time_s, const double x[${M}_N_INPUTS], double *output_um)
{
    double v[${n_terms_1}], lag[${n_terms_1}];
    double dt = 0.0, shift = 0.0, total = 0.0, value;
    int k, j, has_dt = 0;${env_locals}
    *output_um = s->output_um; /* what a refused or held row leaves on the axis */
    /* (1) a negative input to a fractional power */
    for (k = 0; k < ${M}_N_TERMS; k++) {
        if (${P}_fractional[k] && x[${P}_input[k]] < 0.0) return ${P}_refuse(s, time_s, x);
    }
    /* (2) the time */
    if (!isfinite(time_s)) return ${M}_ERR_TIME;
    if (s->started) {
        has_dt = 1;
        dt = time_s - s->time_s;
        if (!(dt > 0.0)) {
${restart}
        }${gap}
    }
    /* (3) every input finite */
    for (j = 0; j < ${M}_N_INPUTS; j++) {
        if (!isfinite(x[j])) return ${P}_refuse(s, time_s, x);
    }
    /* (4) the lags and their weighted sum */
    for (k = 0; k < ${M}_N_TERMS; k++) {
        v[k] = ${P}_power[k] == 1.0 ? x[${P}_input[k]] : pow(x[${P}_input[k]], ${P}_power[k]);
    }
    for (k = 0; k < ${M}_N_TERMS; k++) {
        if (!s->started) {
            lag[k] = (k < ${M}_N_LAGS && ${P}_idle[k < ${M}_N_LAGS ? k : 0]) ? 0.0 : v[k];
        } else if (k < ${M}_N_LAGS) {
            double a = exp(-dt / ${P}_tau[k]);
            lag[k] = (1.0 - a) * v[k] + a * s->lag[k];
        } else {
            lag[k] = v[k];
        }
        total += ${P}_weight[k] * lag[k];
    }
    if (!isfinite(total)) return ${P}_refuse(s, time_s, x);${env_step}
    /* (5) the reference */
    if (!s->started) {
        if (s->has_initial) {
            s->has_start = 1;
            s->start = ${intercept} + total - s->initial;
        } else {
            s->has_start = ${relative};
            s->start = ${relative} ? total : 0.0;
        }
    }
    for (k = 0; k < ${M}_N_TERMS; k++) s->lag[k] = lag[k];${env_store}
    if (s->has_start) total -= s->start;
    /* (6) the model's correction, and the probe filter's */
    value = ${intercept} + total;
${record}
    s->started = 1;
    s->time_s = time_s;
    s->held = 0;
    /* (7) the output stage */
${stage}
    *output_um = s->output_um;
    return ${M}_OK;
}
"""
)


def _trust_c(p):
    """Declarations and functions of the probe filter (Compensator.observe), or ''."""
    if p.trust is None:
        return "", ""
    t = p.trust
    declarations = (
        f"int {p.name}_observe({p.name}_state *s, double time_s, double measured_um);\n"
        f"void {p.name}_recalibrate({p.name}_state *s, int has_size, double size_um);\n"
        f"double {p.name}_half_width(const {p.name}_state *s);\n"
        f"int {p.name}_trusted(const {p.name}_state *s);\n"
    )
    tolerance = (
        "(void)half, 1"
        if p.tolerance_um is None
        else f"isfinite(half) && half <= {_real(p.tolerance_um)}"
    )
    body = Template(
        r"""
#define ${M}_HISTORY ${history}

static double ${P}_corrected(const ${P}_state *s, double model, double time_s)
{
    double dh = (time_s - s->ft0) / 3600.0;
    return model * (1.0 + s->fx[2]) + s->fx[0] * exp(-dh / ${memory_h}) + s->fx[1] * dh;
}

/* the filter's states and covariance carried from its time to time_s */
static void ${P}_propagate(const ${P}_state *s, double time_s, double x[3], double P[9])
{
    double dh = (time_s - s->ft0) / 3600.0, phi, F[9], FP[9];
    int i, j, k;
    if (dh < 0.0) dh = 0.0;
    phi = exp(-dh / ${memory_h});
    F[0] = phi; F[1] = dh; F[2] = 0.0;
    F[3] = 0.0; F[4] = 1.0; F[5] = 0.0;
    F[6] = 0.0; F[7] = 0.0; F[8] = 1.0;
    for (i = 0; i < 3; i++) {
        x[i] = 0.0;
        for (k = 0; k < 3; k++) x[i] += F[3 * i + k] * s->fx[k];
        for (j = 0; j < 3; j++) {
            FP[3 * i + j] = 0.0;
            for (k = 0; k < 3; k++) FP[3 * i + j] += F[3 * i + k] * s->fp[3 * k + j];
        }
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            P[3 * i + j] = 0.0;
            for (k = 0; k < 3; k++) P[3 * i + j] += FP[3 * i + k] * F[3 * j + k];
        }
    }
    P[0] += ${memory_var} * (1.0 - phi * phi);
}

/* h P h for h = (1, 0, m), summed as (h P) h */
static double ${P}_hph(const double P[9], double m)
{
    double r0 = P[0] + m * P[6], r2 = P[2] + m * P[8];
    return r0 + r2 * m;
}

double ${P}_half_width(const ${P}_state *s)
{
    double var;
    if (!s->started) return NAN;
    if (!s->adjusted) {
        double dh = (s->time_s - s->ft0) / 3600.0;
        if (dh < 0.0) dh = 0.0;
        var = ${offset_var} + ${growth_var} * dh + ${noise_var};
    } else {
        double x[3], P[9], hph;
        ${P}_propagate(s, s->time_s, x, P);
        hph = ${P}_hph(P, s->model_um);
        var = (hph > 0.0 ? hph : 0.0) + ${noise_var};
    }
    return ${quantile} * sqrt(var)${widening};
}

int ${P}_trusted(const ${P}_state *s)
{
    double half = ${P}_half_width(s);
    return ${P}_plausible(s) && (${tolerance});
}

void ${P}_recalibrate(${P}_state *s, int has_size, double size_um)
{
    double size2;
    if (!has_size || !isfinite(size_um)) {
        double sd = sqrt(${offset_var} + ${noise_var} > 0.0 ? ${offset_var} + ${noise_var} : 0.0);
        size_um = sd != 0.0 ? sd : 1.0;
    }
    size2 = size_um * size_um;
    s->fp[0] += size2;
    s->fp[4] += size2;
    s->fp[8] += ${gain_var};
    s->changes += 1;
    s->flags[0] = 0.0;
    s->flags[1] = 0.0;
}

int ${P}_observe(${P}_state *s, double time_s, double measured_um)
{
    double m, x[3], P[9], h[3], Ph[3], K[3], IKH[9], A[9], Pn[9];
    double hph, predicted, innovation, S, zs, up, down;
    int i, j, k, oldest, newest, found = 0;
    if (!isfinite(time_s) || !isfinite(measured_um) || !s->started) return ${M}_ERR_READING;
    if (fabs(measured_um) > ${max_correction} || time_s > s->time_s) return ${M}_ERR_READING;
    if (s->has_reading && time_s <= s->last_reading) return ${M}_ERR_READING;
    /* the model's correction at time_s, linear between the rows remembered */
    oldest = s->hcount < ${M}_HISTORY ? 0 : s->hpos;
    newest = (s->hpos + ${M}_HISTORY - 1) % ${M}_HISTORY;
    if (time_s < s->ht[oldest]) return ${M}_ERR_READING;
    m = s->hm[newest];
    for (i = 0; i + 1 < ${M}_HISTORY; i++) {
        if (!found && i + 1 < s->hcount) {
            int j0 = (oldest + i) % ${M}_HISTORY, j1 = (oldest + i + 1) % ${M}_HISTORY;
            if (time_s < s->ht[j1]) {
                double slope = (s->hm[j1] - s->hm[j0]) / (s->ht[j1] - s->ht[j0]);
                m = slope * (time_s - s->ht[j0]) + s->hm[j0];
                found = 1;
            }
        }
    }
    if (!s->adjusted) {
        /* the first reading: the slow part's prior is the batch variance there */
        double dh = (time_s - s->ft0) / 3600.0;
        if (dh < 0.0) dh = 0.0;
        for (i = 0; i < 3; i++) x[i] = 0.0;
        for (i = 0; i < 9; i++) P[i] = s->fp[i];
        P[0] = ${offset_var} + ${growth_var} * dh;
    } else {
        ${P}_propagate(s, time_s, x, P);
    }
    h[0] = 1.0; h[1] = 0.0; h[2] = m;
    predicted = m * (1.0 + x[2]) + x[0];
    innovation = measured_um - predicted;
    hph = ${P}_hph(P, m);
    S = hph + ${noise_var} + ${probe_var};
    if (S <= 0.0) S = 2.2250738585072014e-308; /* no uncertainty at all: the reading is the truth */
    for (i = 0; i < 3; i++) {
        Ph[i] = 0.0;
        for (j = 0; j < 3; j++) Ph[i] += P[3 * i + j] * h[j];
        K[i] = Ph[i] / S;
        x[i] += K[i] * innovation;
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) IKH[3 * i + j] = (i == j ? 1.0 : 0.0) - K[i] * h[j];
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            A[3 * i + j] = 0.0;
            for (k = 0; k < 3; k++) A[3 * i + j] += IKH[3 * i + k] * P[3 * k + j];
        }
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            Pn[3 * i + j] = K[i] * K[j] * (S - hph);
            for (k = 0; k < 3; k++) Pn[3 * i + j] += A[3 * i + k] * IKH[3 * j + k];
        }
    }
    for (i = 0; i < 3; i++) {
        s->fx[i] = x[i];
        for (j = 0; j < 3; j++) s->fp[3 * i + j] = 0.5 * (Pn[3 * i + j] + Pn[3 * j + i]);
    }
    s->ft0 = time_s;
    s->has_ft0 = 1;
    s->adjusted = 1;
    s->has_reading = 1;
    s->last_reading = time_s;
    /* the change detector: a two-sided CUSUM of the standardised innovations */
    zs = innovation / sqrt(S);
    up = s->flags[0] + zs - ${allowance};
    down = s->flags[1] - zs - ${allowance};
    s->flags[0] = up > 0.0 ? up : 0.0;
    s->flags[1] = down > 0.0 ? down : 0.0;
    if ((s->flags[0] > s->flags[1] ? s->flags[0] : s->flags[1]) > ${threshold}) {
        ${P}_recalibrate(s, 1, innovation);
    }
    s->correction_um = ${P}_corrected(s, s->model_um, s->time_s);
    return ${M}_OK;
}
"""
    ).substitute(
        P=p.name,
        M=p.name.upper(),
        history=t.history,
        memory_h=_real(t.memory_h),
        memory_var=_real(t.memory_var),
        offset_var=_real(t.offset_var),
        growth_var=_real(t.growth_var_per_h),
        noise_var=_real(t.noise_var),
        probe_var=_real(t.probe_noise_um**2),
        quantile=_real(t.interval_quantile),
        gain_var=_real(t.gain_var),
        allowance=_real(t.allowance),
        threshold=_real(t.change_threshold),
        max_correction=_real(p.max_correction_um),
        tolerance=tolerance,
        widening="" if p.envelope is None else " + s->widening_um",
    )
    return declarations, body


def _envelope_c(p):
    """The envelope's macros, tables, locals, step and store (update), or '' each."""
    names = ("env_macros", "env_tables", "env_locals", "env_step", "env_store")
    e = p.envelope
    if e is None:
        return dict.fromkeys(names, "")
    P, M, n = p.name, p.name.upper(), len(e.input)
    step = Template(
        r"""
    /* (4b) the envelope: each enveloped input's follower, and the excess bank */
    for (j = 0; j < ${M}_N_INPUTS; j++) xt[j] = x[j];
    for (j = 0; j < ${M}_N_ENV; j++) {
        double xi = x[${P}_env_input[j]], f = xi, lo = ${P}_env_low[j], hi = ${P}_env_high[j];
        if (s->started) {
            double reach = ${P}_env_rate[j] * (dt / 3600.0) * (1.0 + ${M}_RATE_SLACK);
            double down = s->ef[j] - reach, up = s->ef[j] + reach;
            lo = down < lo ? lo : down;
            hi = up > hi ? hi : up;
        }
        if (f < lo) f = lo;
        if (f > hi) f = hi;
        ef[j] = f;
        ex[j] = xi - f;
        xt[${P}_env_input[j]] = f;
        if (outside == 0 && ex[j] != 0.0) outside = ${P}_env_input[j] + 1;
    }
    for (j = 0; j < ${M}_N_ENV; j++) din[j] = 0.0;
    for (k = 0; k < ${M}_N_TERMS; k++) {
        double w = ${P}_power[k] == 1.0 ? xt[${P}_input[k]] : pow(xt[${P}_input[k]], ${P}_power[k]);
        double e = v[k] - w;
        if (!s->started) {
            elag[k] = (k < ${M}_N_LAGS && ${P}_idle[k < ${M}_N_LAGS ? k : 0]) ? 0.0 : e;
        } else if (k < ${M}_N_LAGS) {
            double a = exp(-dt / ${P}_tau[k]);
            elag[k] = (1.0 - a) * e + a * s->elag[k];
        } else {
            elag[k] = e;
        }
        if (${P}_env_slot[k] >= 0) din[${P}_env_slot[k]] += ${P}_weight[k] * elag[k];
    }"""
    ).substitute(P=P, M=M)
    store = Template(
        r"""
    /* the envelope's state; the half-width widens by the model's response to the excess */
    s->has_estart = s->started ? s->has_estart : s->has_start;
    s->widening_um = 0.0;
    for (j = 0; j < ${M}_N_ENV; j++) {
        if (!s->started) s->estart[j] = s->has_start ? din[j] : 0.0;
        s->widening_um += fabs(s->has_estart ? din[j] - s->estart[j] : din[j]);
        s->ef[j] = ef[j];
        s->ex[j] = ex[j];
    }
    for (k = 0; k < ${M}_N_TERMS; k++) s->elag[k] = elag[k];
    s->outside = outside;"""
    ).substitute(P=P, M=M)
    return {
        "env_macros": f"\n#define {M}_N_ENV {n}\n#define {M}_RATE_SLACK {_real(e.rate_slack)}",
        "env_tables": (
            f"\nstatic const int {P}_env_input[{n}] = {_array(e.input, str, 16)};"
            f"\nstatic const double {P}_env_low[{n}] = {_array(e.low)};"
            f"\nstatic const double {P}_env_high[{n}] = {_array(e.high)};"
            f"\nstatic const double {P}_env_rate[{n}] = {_array(e.max_rate_per_h)};"
            f"\nstatic const int {P}_env_slot[{max(len(p.terms), 1)}] = "
            f"{_array(e.term_slot, str, 16)};"
        ),
        "env_locals": (
            f"\n    double ef[{M}_N_ENV], ex[{M}_N_ENV], xt[{M}_N_INPUTS];"
            f"\n    double elag[{max(len(p.terms), 1)}], din[{M}_N_ENV];"
            "\n    int outside = 0;"
        ),
        "env_step": step,
        "env_store": store,
    }


def _record_c(p):
    """Step (6): the probe filter's record of the row, or the model's correction as it is."""
    if p.trust is None:
        return (
            "    (void)shift; /* no filter times to move */\n    s->model_um = value;\n"
            "    s->correction_um = value;"
        )
    return """    if (shift != 0.0) {
        /* the rows' clock restarted (a new piece): move the filter's times with it */
        if (s->has_ft0) s->ft0 -= shift;
        if (s->has_reading) s->last_reading -= shift;
        for (k = 0; k < HISTORY_; k++) s->ht[k] -= shift;
    }
    if (!s->has_ft0) {
        s->ft0 = time_s;
        s->has_ft0 = 1;
    }
    s->ht[s->hpos] = time_s;
    s->hm[s->hpos] = value;
    s->hpos = (s->hpos + 1) % HISTORY_;
    if (s->hcount < HISTORY_) s->hcount += 1;
    s->model_um = value;
    if (s->adjusted) value = PREFIX_corrected(s, value, time_s);
    s->correction_um = value;""".replace("HISTORY_", f"{p.name.upper()}_HISTORY").replace(
        "PREFIX_", f"{p.name}_"
    )


def _stage_c(p):
    """Step (7): :func:`greyml.controller._output.limit_output`, for this compensator's limits."""
    lines = []
    if p.clamp_um is not None:
        c = _real(p.clamp_um)
        lines.append(f"    if (value > {c}) value = {c};")
        lines.append(f"    else if (value < -{c}) value = -{c};")
    rate = None if p.rate_limit_um_s is None else _real(p.rate_limit_um_s)
    if p.quantum_um is None:
        if rate is not None:
            lines += [
                "    {",
                f"        double allowed = has_dt ? {rate} * dt : 0.0;",
                "        double lo = s->last - allowed, hi = s->last + allowed;",
                "        value = value > lo ? value : lo;",
                "        value = value < hi ? value : hi;",
                "    }",
            ]
        else:
            lines.append("    (void)has_dt; /* no rate limit */")
        lines += ["    s->last = value;", "    s->output_um = value;"]
        return "\n".join(lines)
    q = _real(p.quantum_um)
    lines += [
        "    {",
        f"        double m = fabs(value) / {q} + 0.5, count;",
        f"        if (m > {_real(QUANTA_MAX)}) m = {_real(QUANTA_MAX)};",
        "        count = floor(m);",
        "        if (value < 0.0) count = -count;",
    ]
    if rate is not None:
        lines += [
            "        if (has_dt) {",
            f"            double credit = s->credit_um + {rate} * dt;",
            f"            double cap = {rate} * dt >= {q} ? {rate} * dt : {q};",
            "            s->credit_um = credit < cap ? credit : cap;",
            "        }",
            "        {",
            "            double d = count - s->last, moved = fabs(d);",
            f"            double allowed = s->credit_um / {q} + {_real(QUANTUM_TOLERANCE)};",
            "            moved = floor(moved < allowed ? moved : allowed);",
            "            count = d > 0.0 ? s->last + moved : s->last - moved;",
            f"            s->credit_um -= moved * {q};",
            "            if (s->credit_um < 0.0) s->credit_um = 0.0;",
            "        }",
        ]
    else:
        lines.append("        (void)has_dt; /* no rate limit */")
    lines += ["        s->last = count;", f"        s->output_um = count * {q};", "    }"]
    return "\n".join(lines)


def write_c(p):
    """The C source of :class:`Program` ``p``, as text."""
    n_terms, n_lags = len(p.terms), p.n_lags
    M = p.name.upper()
    declarations, functions = _trust_c(p)
    status_macros = "\n".join(
        f"#define {M}_{key} ({code})" for key, (code, _) in STATUS_CODES.items()
    )
    input_macros = "\n".join(
        f"#define {M}_IN_{v.identifier.upper()} {j} /* {v.comment}, {v.unit} */"
        for j, v in enumerate(p.inputs)
    )
    if p.nominal_step_s is None:
        restart = f"            return {M}_ERR_TIME;"
    else:
        restart = (
            "            /* the next piece of the recording: its clock starts anew */\n"
            f"            dt = {_real(p.nominal_step_s)};\n"
            "            shift = s->time_s + dt - time_s;"
        )
    gap = (
        ""
        if p.max_step_s is None
        else (
            f" else if (dt > {_real(p.max_step_s)}) {{\n            return {M}_ERR_GAP;\n        }}"
        )
    )
    if p.hold:
        missing = f"            s->held = 1;\n            return {M}_HELD;"
    else:
        missing = (
            "            (void)s; /* refused: no state changes */\n"
            f"            return {M}_ERR_VALUE;"
        )
    stage = _stage_c(p)
    source = _TEMPLATE.substitute(
        P=p.name,
        M=M,
        n_inputs=len(p.inputs),
        n_terms=n_terms,
        n_lags=n_lags,
        n_terms_1=max(n_terms, 1),
        n_lags_1=max(n_lags, 1),
        status_macros=status_macros,
        input_macros=input_macros,
        members=_struct(p),
        trust_declarations=declarations,
        trust_functions=functions,
        input_index=_array([t.input for t in p.terms], str, 16),
        powers=_array([t.power for t in p.terms]),
        fractional=_array([int(t.fractional) for t in p.terms], str, 16),
        weights=_array([t.weight for t in p.terms]),
        taus=_array([t.tau_s for t in p.terms[:n_lags]]),
        idle=_array([int(t.idle) for t in p.terms[:n_lags]], str, 16),
        max_correction=_real(p.max_correction_um),
        missing=missing,
        restart=restart,
        gap=gap,
        intercept=_real(p.intercept),
        relative=int(p.relative_to_start),
        record=_record_c(p),
        stage=stage,
        **_envelope_c(p),
    )
    call = (
        f"{p.name}_init once, {p.name}_update at every row (time_s and the inputs), "
        "*output_um is the output"
    )
    return _header(p, header_lines(p, "C99", call)) + source
