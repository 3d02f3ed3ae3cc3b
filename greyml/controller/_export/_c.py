"""A Compensator as one self-contained C99 file, written from its :class:`Program`.

The file declares a state struct and the functions ``<name>_init``,
``<name>_reset``, ``<name>_update`` and (with a calibration) ``<name>_observe``,
``<name>_recalibrate``, ``<name>_half_width``, ``<name>_trusted``,
``<name>_change_kind``, ``<name>_change_start_s`` and ``<name>_innovation``,
with the arithmetic and the order of checks of
:meth:`greyml.Compensator.update` and :meth:`~greyml.Compensator.observe`.
Every loop runs over a compile-time constant (the terms, the inputs, the 512
rows of the probe filter's ring, the change detector's 12 onsets), nothing is
allocated, and only ``<math.h>`` is used.
"""

from __future__ import annotations

import math
import textwrap
from string import Template

from greyml.controller._export._program import ARRAYS, CHANGE_KINDS, STATUS_CODES
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


def header_lines(p, language, call, found=""):
    """The header's lines, shared by the C and Structured Text writers (``found``:
    where the language gives what the change detector found)."""
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
            f"observe (a Kalman filter on the error's offset, bias and bias rate, "
            f"{p.trust.history} rows remembered for late readings; a likelihood test for a "
            f"step or a ramp that began within the last {p.trust.window} readings, at most "
            f"{p.trust.false_alarm_rate:g} false alarms per reading on unchanged readings: "
            f"threshold {p.trust.glr_threshold:.6g}). {found}"
            if p.trust is not None
            else "none (the model has no calibration)."
        ),
        *(() if p.envelope is None else p.envelope.lines(p.inputs, "Structured" in language)),
        "Status codes (update, observe):",
        *(f"  {code:2d} {key}: {meaning}." for key, (code, meaning) in STATUS_CODES.items()),
        "Not safety-certified. Validate it on the machine before it moves an axis.",
    ]
    return lines


_KINDS = {"real": "double", "int": "long", "bool": "int"}


def _init_body(p):
    """Every state member and the work space zeroed (no struct on the stack)."""
    zero = {"real": "0.0", "int": "0", "bool": "0"}
    lines, used = [], False
    members = [(v.name, v.kind, v.length, v.length > 1 or v.name in ARRAYS) for v in p.state]
    n_terms = max(len(p.terms), 1)
    members.append(("work_lag", "real", n_terms, True))
    if p.envelope is not None:
        n_env, n_inputs = len(p.envelope.input), max(len(p.inputs), 1)
        members += [
            ("work_elag", "real", n_terms, True),
            ("work_xt", "real", n_inputs, True),
            ("work_ef", "real", n_env, True),
            ("work_ex", "real", n_env, True),
            ("work_din", "real", n_env, True),
        ]
    for name, kind, length, array in members:
        if array:
            used = True
            lines.append(f"    for (k = 0; k < {max(length, 1)}; k++) s->{name}[k] = {zero[kind]};")
        else:
            lines.append(f"    s->{name} = {zero[kind]};")
    if not used:
        lines.append("    (void)k;")
    return "\n".join(lines)


def _struct(p):
    members = []
    for v in p.state:
        size = f"[{max(v.length, 1)}]" if v.length > 1 or v.name in ARRAYS else ""
        unit = f" ({v.unit})" if v.unit else ""
        members.append(f"    {_KINDS[v.kind]} {v.name}{size}; /* {v.meaning}{unit} */")
    # the work space of an update: in the caller's struct, never on the stack (a model
    # of 100,000 terms needs no stack of its size), and meaningless between calls
    n_terms = max(len(p.terms), 1)
    members.append(f"    double work_lag[{n_terms}]; /* work space: each term's new lag */")
    if p.envelope is not None:
        n_env, n_inputs = len(p.envelope.input), max(len(p.inputs), 1)
        members += [
            f"    double work_elag[{n_terms}]; /* work space: each term's new excess lag */",
            f"    double work_xt[{n_inputs}]; /* work space: the inputs on their followers */",
            f"    double work_ef[{n_env}]; /* work space: the new followers */",
            f"    double work_ex[{n_env}]; /* work space: the new excesses */",
            f"    double work_din[{n_env}]; /* work space: each input's response */",
        ]
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
int ${P}_update(${P}_state *s, double time_s, const double x[], double *output_um);
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
    /* member by member: a zero struct copied in would be the struct's size on the stack */
    int k;
${init}
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
int ${P}_update(${P}_state *s, double time_s, const double x[], double *output_um)
{
    double dt = 0.0, shift = 0.0, total = 0.0, start, model, value;
    int k, j, has_dt = 0, has_start;${env_locals}
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
    /* (3) every input finite, before anything changes */
    for (j = 0; j < ${M}_N_INPUTS; j++) {
        if (!isfinite(x[j])) return ${P}_refuse(s, time_s, x);
    }
    /* (4) the lags, into the work space (nothing is kept before the checks), and their
       weighted sum, term after term (as Python adds them) */
    for (k = 0; k < ${M}_N_TERMS; k++) {
        double v = ${P}_power[k] == 1.0 ? x[${P}_input[k]] : pow(x[${P}_input[k]], ${P}_power[k]);
        double lag;
        if (!s->started) {
            lag = (k < ${M}_N_LAGS && ${P}_idle[k < ${M}_N_LAGS ? k : 0]) ? 0.0 : v;
        } else if (k < ${M}_N_LAGS) {
            double a = exp(-dt / ${P}_tau[k]);
            lag = (1.0 - a) * v + a * s->lag[k];
        } else {
            lag = v;
        }
        s->work_lag[k] = lag;
        total += ${P}_weight[k] * lag;
    }
    if (!isfinite(total)) return ${P}_refuse(s, time_s, x);${env_step}
    /* (5) the reference */
    has_start = s->has_start;
    start = s->start;
    if (!s->started) {
        if (s->has_initial) {
            has_start = 1;
            start = ${intercept} + total - s->initial;
        } else {
            has_start = ${relative};
            start = ${relative} ? total : 0.0;
        }
    }
    if (has_start) total -= start;
    /* (6) the model's correction, and the probe filter's: refused if not finite or beyond
       max_correction_um, before anything is kept */
    model = ${intercept} + total;
    value = model;${filter_value}
    if (!isfinite(value) || fabs(value) > ${max_correction}) return ${M}_ERR_VALUE;
    s->has_start = has_start;
    s->start = start;
    for (k = 0; k < ${M}_N_TERMS; k++) s->lag[k] = s->work_lag[k];${env_store}
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
        f"int {p.name}_recalibrate({p.name}_state *s, int has_size, double size_um);\n"
        f"double {p.name}_half_width(const {p.name}_state *s);\n"
        f"int {p.name}_trusted(const {p.name}_state *s);\n"
        f"int {p.name}_change_kind(const {p.name}_state *s);\n"
        f"double {p.name}_change_start_s(const {p.name}_state *s);\n"
        f"double {p.name}_innovation(const {p.name}_state *s);\n"
    )
    tolerance = (
        "(void)half, 1"
        if p.tolerance_um is None
        else f"isfinite(half) && half <= {_real(p.tolerance_um)}"
    )
    body = Template(
        r"""
#define ${M}_HISTORY ${history}
#define ${M}_WINDOW ${window}
${change_macros}

/* the model's correction with the filter's states carried from ft0 to time_s */
static double ${P}_corrected(const ${P}_state *s, double model, double time_s, double ft0)
{
    double dh = (time_s - ft0) / 3600.0;
    return model + s->fx[0] * exp(-dh / ${memory_h}) + s->fx[1] + s->fx[2] * dh;
}

/* the change detector's bank: a copy that a reading works on, kept only if it is finite */
typedef struct {
    double d[2 * ${M}_WINDOW * 3], a[2 * ${M}_WINDOW], b[2 * ${M}_WINDOW], t0[${M}_WINDOW];
    long n;
} ${P}_bank;

static void ${P}_bank_clear(${P}_bank *g)
{
    int i;
    for (i = 0; i < 2 * ${M}_WINDOW * 3; i++) g->d[i] = 0.0;
    for (i = 0; i < 2 * ${M}_WINDOW; i++) {
        g->a[i] = 0.0;
        g->b[i] = 0.0;
    }
    for (i = 0; i < ${M}_WINDOW; i++) g->t0[i] = 0.0;
    g->n = 0;
}

static void ${P}_bank_load(const ${P}_state *s, ${P}_bank *g)
{
    int i;
    for (i = 0; i < 2 * ${M}_WINDOW * 3; i++) g->d[i] = s->glr_d[i];
    for (i = 0; i < 2 * ${M}_WINDOW; i++) {
        g->a[i] = s->glr_a[i];
        g->b[i] = s->glr_b[i];
    }
    for (i = 0; i < ${M}_WINDOW; i++) g->t0[i] = s->glr_t0[i];
    g->n = s->glr_n;
}

static void ${P}_bank_store(${P}_state *s, const ${P}_bank *g)
{
    int i;
    for (i = 0; i < 2 * ${M}_WINDOW * 3; i++) s->glr_d[i] = g->d[i];
    for (i = 0; i < 2 * ${M}_WINDOW; i++) {
        s->glr_a[i] = g->a[i];
        s->glr_b[i] = g->b[i];
    }
    for (i = 0; i < ${M}_WINDOW; i++) s->glr_t0[i] = g->t0[i];
    s->glr_n = g->n;
}

/* the filter's transition over dh hours (>= 0): F, and Q (the random walks, scaled) */
static void ${P}_transition(double dh, double F[9], double Q[9])
{
    double phi = exp(-dh / ${memory_h});
    F[0] = phi; F[1] = 0.0; F[2] = 0.0;
    F[3] = 0.0; F[4] = 1.0; F[5] = dh;
    F[6] = 0.0; F[7] = 0.0; F[8] = 1.0;
    Q[0] = ${scale} * (${memory_var} * (1.0 - phi * phi)); Q[1] = 0.0; Q[2] = 0.0;
    Q[3] = 0.0;
    Q[4] = ${scale} * (${bias_var} * dh + ${rate_var} * pow(dh, 3.0) / 3.0);
    Q[5] = ${scale} * (${rate_var} * dh * dh / 2.0);
    Q[6] = 0.0; Q[7] = Q[5]; Q[8] = ${scale} * (${rate_var} * dh);
}

/* the filter's states and covariance carried from its time to time_s (F x, F P F' + Q) */
static void ${P}_propagate(const ${P}_state *s, double time_s, double x[3], double P[9],
                           double F[9])
{
    double dh = (time_s - s->ft0) / 3600.0, Q[9], FP[9];
    int i, j, k;
    if (dh < 0.0) dh = 0.0;
    ${P}_transition(dh, F, Q);
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
            P[3 * i + j] += Q[3 * i + j];
        }
    }
}

double ${P}_half_width(const ${P}_state *s)
{
    double var, dh;
    if (!s->started) return NAN;
    dh = (s->time_s - s->ft0) / 3600.0;
    if (dh < 0.0) dh = 0.0;
    if (!s->adjusted) {
        var = ${offset_var} + ${growth_var} * dh + ${noise_var};
    } else {
        /* H (F P F' + Q) H' with H F = (phi, 1, dh), in scalars, as Python computes it */
        const double *P = s->fp;
        double phi = exp(-dh / ${memory_h}), hph, hqh;
        hph = phi * phi * P[0] + P[4] + dh * dh * P[8]
            + 2.0 * (phi * P[1] + phi * dh * P[2] + dh * P[5]);
        hqh = ${memory_var} * (1.0 - phi * phi) + ${bias_var} * dh;
        hqh += ${rate_var} * pow(dh, 3.0) / 3.0;
        var = hph + ${scale} * hqh;
        if (isnan(var)) var = HUGE_VAL; /* inf - inf: nothing is known */
        var = (var > 0.0 ? var : 0.0) + ${white_var};
    }
    return ${quantile} * sqrt(var)${widening};
}

int ${P}_trusted(const ${P}_state *s)
{
    double half = ${P}_half_width(s);
    return ${P}_plausible(s) && (${tolerance});
}

int ${P}_change_kind(const ${P}_state *s)
{
    return (int)s->change_kind;
}

double ${P}_change_start_s(const ${P}_state *s)
{
    return s->change_kind != ${M}_CHANGE_NONE ? s->change_start_s : NAN;
}

double ${P}_innovation(const ${P}_state *s)
{
    return s->adjusted ? s->innovation : NAN;
}

int ${P}_recalibrate(${P}_state *s, int has_size, double size_um)
{
    double size2, b, r;
    ${P}_bank g;
    if (!has_size) {
        double sd = sqrt(${offset_var} + ${noise_var} > 0.0 ? ${offset_var} + ${noise_var} : 0.0);
        size_um = sd != 0.0 ? sd : 1.0;
    } else if (!isfinite(size_um) || fabs(size_um) > ${max_correction}) {
        return ${M}_ERR_READING; /* as Compensator.recalibrate refuses it: nothing changes */
    }
    size2 = size_um * size_um;
    b = s->fp[4] + size2;
    r = s->fp[8] + size2;
    if (!isfinite(b) || !isfinite(r)) return ${M}_ERR_READING;
    s->fp[4] = b;
    s->fp[8] = r;
    s->changes += 1;
    ${P}_bank_clear(&g);
    ${P}_bank_store(s, &g);
    return ${M}_OK;
}

/* the likelihood test after a reading (Willsky and Jones, 1976): the bank advanced by
   one onset; returns the kind (0 step, 1 ramp) and onset of the largest statistic */
static double ${P}_glr_advance(${P}_bank *g, const double F[9], const double K[3],
                               double innovation, double S, double time_h, double previous_h,
                               int *kind, int *slot)
{
    double best = 0.0;
    int c, i, j, k;
    for (j = 0; j + 1 < ${M}_WINDOW; j++) {
        int to = ${M}_WINDOW - 1 - j, from = ${M}_WINDOW - 2 - j;
        g->t0[to] = g->t0[from];
        for (c = 0; c < 2; c++) {
            int at = c * ${M}_WINDOW + to, was = c * ${M}_WINDOW + from;
            g->a[at] = g->a[was];
            g->b[at] = g->b[was];
            for (i = 0; i < 3; i++) g->d[3 * at + i] = g->d[3 * was + i];
        }
    }
    g->t0[0] = previous_h;
    for (c = 0; c < 2; c++) {
        g->a[c * ${M}_WINDOW] = 0.0;
        g->b[c * ${M}_WINDOW] = 0.0;
        for (i = 0; i < 3; i++) g->d[c * ${M}_WINDOW * 3 + i] = 0.0;
    }
    if (g->n < ${M}_WINDOW) g->n += 1;
    *kind = 0;
    *slot = 0;
    for (c = 0; c < 2; c++) {
        for (j = 0; j < ${M}_WINDOW; j++) {
            if (j < g->n) {
                double *d = g->d + (c * ${M}_WINDOW + j) * 3, e[3], g1, rho, a, b, stat;
                for (i = 0; i < 3; i++) {
                    e[i] = 0.0;
                    for (k = 0; k < 3; k++) e[i] += d[k] * F[3 * i + k];
                }
                g1 = c == 0 ? 1.0 : time_h - g->t0[j];
                rho = (0.0 - e[0]) + (g1 - e[1]); /* H (g - d) */
                for (i = 0; i < 3; i++) d[i] = e[i] + rho * K[i];
                a = g->a[c * ${M}_WINDOW + j] += rho * innovation / S;
                b = g->b[c * ${M}_WINDOW + j] += rho * rho / S;
                stat = b > 0.0 ? a * a / b : 0.0;
                if (c == 1 && j == 0) stat = 0.0; /* a ramp read once is the step */
                if ((c == 0 && j == 0) || stat > best) {
                    best = stat;
                    *kind = c;
                    *slot = j;
                }
            }
        }
    }
    return best;
}

int ${P}_observe(${P}_state *s, double time_s, double measured_um)
{
    double m, x[3], P[9], F[9], PH[3], K[3], IKH[9], A[9], Pn[9];
    double dh, innovation, S, previous, stat, standardised, corrected;
    long oldest, newest, i, j, k;
    int kind, slot, found = 0, ok, change_kind = (int)s->change_kind;
    long changes = s->changes;
    double change_start_s = s->change_start_s;
    ${P}_bank g;
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
            long j0 = (oldest + i) % ${M}_HISTORY, j1 = (oldest + i + 1) % ${M}_HISTORY;
            if (time_s < s->ht[j1]) {
                double slope = (s->hm[j1] - s->hm[j0]) / (s->ht[j1] - s->ht[j0]);
                m = slope * (time_s - s->ht[j0]) + s->hm[j0];
                found = 1;
            }
        }
    }
    /* everything below works on copies: the state changes only once all is finite */
    previous = s->ft0;
    ${P}_propagate(s, time_s, x, P, F);
    if (!s->adjusted) {
        /* the first reading: the batch variance there, all in the offset */
        dh = (time_s - s->ft0) / 3600.0;
        if (dh < 0.0) dh = 0.0;
        for (i = 0; i < 3; i++) x[i] = 0.0;
        for (i = 0; i < 9; i++) P[i] = s->fp[i]; /* open only where recalibrate opened it */
        P[0] = ${scale} * (${offset_var} + ${growth_var} * dh);
    }
    /* the Kalman update, H = (1, 1, 0), Joseph form */
    innovation = (measured_um - m) - (x[0] + x[1]);
    for (i = 0; i < 3; i++) PH[i] = P[3 * i] + P[3 * i + 1];
    S = (PH[0] + PH[1]) + ${reading_var};
    if (S <= 0.0) S = 2.2250738585072014e-308; /* no uncertainty at all: the reading is the truth */
    for (i = 0; i < 3; i++) {
        K[i] = PH[i] / S;
        for (j = 0; j < 3; j++) IKH[3 * i + j] = (i == j ? 1.0 : 0.0) - K[i] * (j < 2 ? 1.0 : 0.0);
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            A[3 * i + j] = 0.0;
            for (k = 0; k < 3; k++) A[3 * i + j] += IKH[3 * i + k] * P[3 * k + j];
        }
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            Pn[3 * i + j] = 0.0;
            for (k = 0; k < 3; k++) Pn[3 * i + j] += A[3 * i + k] * IKH[3 * j + k];
            Pn[3 * i + j] += K[i] * K[j] * ${reading_var};
        }
    }
    for (i = 0; i < 3; i++) {
        x[i] += K[i] * innovation;
        for (j = 0; j < 3; j++) P[3 * i + j] = 0.5 * (Pn[3 * i + j] + Pn[3 * j + i]);
    }
    /* the change detector: a step or a ramp since one of the last readings */
    ${P}_bank_load(s, &g);
    stat = ${P}_glr_advance(&g, F, K, innovation, S, time_s / 3600.0, previous / 3600.0, &kind,
                            &slot);
    if (stat > ${threshold}) {
        const double *d = g.d + (kind * ${M}_WINDOW + slot) * 3;
        double miss[3], b = g.b[kind * ${M}_WINDOW + slot];
        double size = g.a[kind * ${M}_WINDOW + slot] / b;
        miss[0] = 0.0 - d[0];
        miss[1] = (kind == 0 ? 1.0 : time_s / 3600.0 - g.t0[slot]) - d[1];
        miss[2] = (kind == 0 ? 0.0 : 1.0) - d[2];
        for (i = 0; i < 3; i++) {
            x[i] += size * miss[i];
            for (j = 0; j < 3; j++) P[3 * i + j] += miss[i] * miss[j] / b;
        }
        {
            /* a few readings cannot tell a step from a ramp: the bias and the rate
               are opened by the size found (its effect here, and per hour since) */
            double span = time_s / 3600.0 - g.t0[slot], effect2;
            if (span < 1e-9) span = 1e-9;
            effect2 = kind ? (size * span) * (size * span) : size * size;
            P[4] += effect2;
            P[8] += effect2 / (span * span);
        }
        change_kind = kind + 1;
        change_start_s = g.t0[slot] * 3600.0;
        changes += 1;
        ${P}_bank_clear(&g);
    }
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) Pn[3 * i + j] = 0.5 * (P[3 * i + j] + P[3 * j + i]);
    }
    standardised = innovation / sqrt(S);
    dh = (s->time_s - time_s) / 3600.0;
    corrected = s->model_um + x[0] * exp(-dh / ${memory_h}) + x[1] + x[2] * dh;
    ok = isfinite(standardised) && isfinite(corrected);
    for (i = 0; i < 3; i++) ok = ok && isfinite(x[i]);
    for (i = 0; i < 9; i++) ok = ok && isfinite(Pn[i]);
    for (i = 0; i < 2 * ${M}_WINDOW * 3; i++) ok = ok && isfinite(g.d[i]);
    for (i = 0; i < 2 * ${M}_WINDOW; i++) ok = ok && isfinite(g.a[i]) && isfinite(g.b[i]);
    if (!ok) return ${M}_ERR_READING; /* the reading overflows the filter: nothing changes */
    for (i = 0; i < 3; i++) s->fx[i] = x[i];
    for (i = 0; i < 9; i++) s->fp[i] = Pn[i];
    ${P}_bank_store(s, &g);
    s->change_kind = change_kind;
    s->change_start_s = change_start_s;
    s->changes = changes;
    s->ft0 = time_s;
    s->has_ft0 = 1;
    s->adjusted = 1;
    s->has_reading = 1;
    s->last_reading = time_s;
    s->innovation = standardised;
    s->correction_um = corrected;
    return ${M}_OK;
}
"""
    ).substitute(
        P=p.name,
        M=p.name.upper(),
        history=t.history,
        window=t.window,
        memory_h=_real(t.memory_h),
        memory_var=_real(t.memory_var),
        bias_var=_real(t.bias_var_per_h),
        rate_var=_real(t.rate_var_per_h3),
        scale=_real(t.scale),
        offset_var=_real(t.offset_var),
        growth_var=_real(t.growth_var_per_h),
        noise_var=_real(t.noise_var),
        reading_var=_real(t.reading_var),
        white_var=_real(t.white_var),
        quantile=_real(t.interval_quantile),
        threshold=_real(t.glr_threshold),
        change_macros="\n".join(
            f"#define {p.name.upper()}_CHANGE_{kind.upper()} {code}"
            for kind, code in CHANGE_KINDS.items()
        ),
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
    for (j = 0; j < ${M}_N_INPUTS; j++) s->work_xt[j] = x[j];
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
        s->work_ef[j] = f;
        s->work_ex[j] = xi - f;
        s->work_xt[${P}_env_input[j]] = f;
        if (outside == 0 && s->work_ex[j] != 0.0) outside = ${P}_env_input[j] + 1;
    }
    for (j = 0; j < ${M}_N_ENV; j++) s->work_din[j] = 0.0;
    for (k = 0; k < ${M}_N_TERMS; k++) {
        double xk = x[${P}_input[k]], xtk = s->work_xt[${P}_input[k]];
        double v = ${P}_power[k] == 1.0 ? xk : pow(xk, ${P}_power[k]);
        double w = ${P}_power[k] == 1.0 ? xtk : pow(xtk, ${P}_power[k]);
        double e = v - w, elag;
        if (!s->started) {
            elag = (k < ${M}_N_LAGS && ${P}_idle[k < ${M}_N_LAGS ? k : 0]) ? 0.0 : e;
        } else if (k < ${M}_N_LAGS) {
            double a = exp(-dt / ${P}_tau[k]);
            elag = (1.0 - a) * e + a * s->elag[k];
        } else {
            elag = e;
        }
        s->work_elag[k] = elag;
        if (${P}_env_slot[k] >= 0) s->work_din[${P}_env_slot[k]] += ${P}_weight[k] * elag;
    }"""
    ).substitute(P=P, M=M)
    store = Template(
        r"""
    /* the envelope's state; the half-width widens by the model's response to the excess */
    s->has_estart = s->started ? s->has_estart : s->has_start;
    s->widening_um = 0.0;
    for (j = 0; j < ${M}_N_ENV; j++) {
        double din = s->work_din[j];
        if (!s->started) s->estart[j] = s->has_start ? din : 0.0;
        s->widening_um += fabs(s->has_estart ? din - s->estart[j] : din);
        s->ef[j] = s->work_ef[j];
        s->ex[j] = s->work_ex[j];
    }
    for (k = 0; k < ${M}_N_TERMS; k++) s->elag[k] = s->work_elag[k];
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
        "env_locals": "\n    int outside = 0;",
        "env_step": step,
        "env_store": store,
    }


def _record_c(p):
    """Step (6): the probe filter's record of the row, or the model's correction as it is."""
    if p.trust is None:
        return (
            "    (void)shift; /* no filter times to move */\n    s->model_um = model;\n"
            "    s->correction_um = value;"
        )
    return (
        """    if (shift != 0.0) {
        /* the rows' clock restarted (a new piece): move the filter's times with it */
        if (s->has_ft0) s->ft0 -= shift;
        if (s->has_reading) s->last_reading -= shift;
        for (k = 0; k < HISTORY_; k++) s->ht[k] -= shift;
        for (k = 0; k < WINDOW_; k++) {
            if (k < s->glr_n) s->glr_t0[k] -= shift / 3600.0;
        }
        if (s->change_kind != 0) s->change_start_s -= shift;
    }
    if (!s->has_ft0) {
        s->ft0 = time_s;
        s->has_ft0 = 1;
    }
    s->ht[s->hpos] = time_s;
    s->hm[s->hpos] = model;
    s->hpos = (s->hpos + 1) % HISTORY_;
    if (s->hcount < HISTORY_) s->hcount += 1;
    s->model_um = model;
    s->correction_um = value;""".replace("HISTORY_", f"{p.name.upper()}_HISTORY")
        .replace("WINDOW_", f"{p.name.upper()}_WINDOW")
        .replace("PREFIX_", f"{p.name}_")
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
        init=_init_body(p),
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
        filter_value=(
            ""
            if p.trust is None
            else f"\n    if (s->adjusted) value = {p.name}_corrected(s, model, time_s, "
            "s->ft0 - shift);"
        ),
        stage=stage,
        **_envelope_c(p),
    )
    call = (
        f"{p.name}_init once, {p.name}_update at every row (time_s and the inputs), "
        "*output_um is the output"
    )
    found = (
        f"What it found: {p.name}_change_kind (0 none, 1 step, 2 ramp), "
        f"{p.name}_change_start_s (when it began, s on the rows' clock; NaN before one is "
        f"found), {p.name}_innovation (the last reading's standardised innovation; NaN "
        f"before a reading); changes counts its firings and the recalibrations."
    )
    return _header(p, header_lines(p, "C99", call, found)) + source
