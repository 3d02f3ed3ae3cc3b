"""One description of a Compensator's computation, from which every export is written.

:func:`describe` turns a compensator's plan (its terms and inputs checked,
never taken from a file) and its parameters into a :class:`Program`: the
numbers (per term the input it reads, its power, time constant, weight and
whether it starts idle; the intercept; the limits; the probe filter's
calibration), the policies (reference, restarting clock, missing inputs), the
layout of the running state, and the names that may appear in generated text,
made safe. The C and Structured Text writers render the same fixed algorithm
(``Compensator.update``'s order of checks, the lags, the output stage of
:func:`greyml.controller._output.limit_output`, the probe filter of
:mod:`greyml.controller._compensator`) from it, and the JSON export is
:meth:`Program.to_dict`.

Nothing a model file says reaches generated code as text except through
:func:`identifier` (letters, digits and single underscores, with a prefix) and
:func:`comment_text` (a short run of harmless characters).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from greyml.controller._compensator import HISTORY
from greyml.controller._output import QUANTA_MAX, QUANTUM_TOLERANCE
from greyml.dynamic._envelope import RATE_SLACK
from greyml.dynamic._observer import KINDS, WINDOW, glr_threshold

__all__ = [
    "CHANGE_KINDS",
    "RESERVED_WORDS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "STATUS_CODES",
    "Program",
    "check_name",
    "comment_text",
    "describe",
    "identifier",
]

#: The JSON export's schema: its name and version (a reader checks both).
SCHEMA = "greyml.compensator-export"
SCHEMA_VERSION = 1

#: The change detector's kinds as the exports code them (0: it has not fired).
CHANGE_KINDS = {"none": 0, **{kind: k + 1 for k, kind in enumerate(KINDS)}}

#: What update and observe return, in every export (Python raises instead of
#: the negative ones, with the same one-line message as for a refused row).
STATUS_CODES = {
    "OK": (0, "the row was taken"),
    "HELD": (1, "an input was missing (NaN or infinite): the last output again, no state changed"),
    "ERR_TIME": (-1, "time_s not finite, or not later than the previous row's: refused"),
    "ERR_GAP": (-2, "the step is longer than max_step_s: refused (reset to start anew)"),
    "ERR_VALUE": (
        -3,
        "an input missing (on_missing='raise'), negative to a fractional power, or the "
        "correction not finite or beyond max_correction_um: refused, no state changed",
    ),
    "ERR_READING": (
        -4,
        "a probe reading or a recalibration size refused (as Compensator.observe and "
        "recalibrate refuse them): no state changed",
    ),
}

# Words a function or block name may not be (case-insensitive, as Structured Text reads
# them): the keywords of C99 and C11; of IEC 61131-3 (third edition: its statements,
# sections, types and operators, the object-oriented extensions, namespaces, SFC); the
# extensions of TwinCAT 3 and CODESYS 3.5 (properties, references, unions, pointers,
# JMP, the qualifiers of VAR sections); and the standard functions the function block
# calls. An input's identifier always has a prefix (x_), so it is none of them.
_C_KEYWORDS = """
    auto break case char const continue default do double else enum extern float for goto
    if inline int long register restrict return short signed sizeof static struct switch
    typedef union unsigned void volatile while bool complex imaginary alignas alignof
    atomic generic noreturn static_assert thread_local int8_t int16_t int32_t int64_t
    uint8_t uint16_t uint32_t uint64_t size_t main nan infinity huge_val
"""
_IEC_KEYWORDS = """
    action end_action array at by case end_case class end_class configuration
    end_configuration constant continue do else elsif end_for end_function
    end_function_block end_if end_interface end_method end_namespace end_program
    end_repeat end_resource end_step end_struct end_transition end_type end_var end_while
    en eno exit extends f_edge r_edge false final for from function function_block if
    implements initial_step interface internal method namespace non_retain null of on
    or override private program protected public read_only read_write ref ref_to repeat
    resource retain return step struct super task then this to transition true type
    until using var var_access var_config var_external var_global var_in_out var_input
    var_output var_temp var_stat var_inst while with abstract and and_then or_else xor
    not mod
    bool byte word dword lword sint int dint lint usint uint udint ulint real lreal time
    ltime date ldate time_of_day tod ltod date_and_time dt ldt string wstring char wchar
    any any_num any_real any_int any_bit any_string any_date any_elementary any_derived
    any_magnitude any_signed any_unsigned any_duration any_char any_chars
"""
_VENDOR_KEYWORDS = """
    property end_property reference pointer union end_union jmp persistent adr adrinst
    bitadr sizeof ini xword xint uxint bit jmpc jmpcn cal calc calcn ret retc retcn
    var_in_out_constant end_class interface end_interface
    abs exp expt sqrt trunc ln log sin cos tan asin acos atan min max limit sel mux
    dint_to_lreal lreal_to_dint
"""
_RESERVED = frozenset((_C_KEYWORDS + _IEC_KEYWORDS + _VENDOR_KEYWORDS).split())

#: Every word refused as a name, in upper case (what the tests try).
RESERVED_WORDS = tuple(sorted(w.upper() for w in _RESERVED))

_NAME = re.compile(r"[A-Za-z](?:_?[A-Za-z0-9])*")
_NAME_MAX = 31


def check_name(name):
    """``name`` if it is a safe function (C) and block (Structured Text) name, else one line."""
    if not (
        isinstance(name, str)
        and len(name) <= _NAME_MAX
        and _NAME.fullmatch(name)
        and name.lower() not in _RESERVED
    ):
        shown = comment_text(str(name)) if isinstance(name, str) else type(name).__name__
        raise ValueError(
            f"Compensator.export: the name {shown!r} is not a C and Structured Text "
            f"identifier: a letter, then letters, digits and single underscores, at most "
            f"{_NAME_MAX} characters, not a keyword."
        )
    return name


def identifier(name, taken, prefix="x_"):
    """A harmless identifier for the input ``name``: ``prefix`` and its letters and digits.

    Anything else becomes one underscore (Structured Text allows no double
    underscore and none at the end); the result is at most 31 characters and
    differs, ignoring case (Structured Text's rule), from every name in
    ``taken``, which it is added to.
    """
    core = re.sub(r"[^A-Za-z0-9]+", "_", str(name)).strip("_") or "input"
    base = (prefix + core)[:_NAME_MAX].rstrip("_")
    candidate, k = base, 2
    while candidate.lower() in taken:
        suffix = f"_{k}"
        candidate = base[: _NAME_MAX - len(suffix)].rstrip("_") + suffix
        k += 1
    taken.add(candidate.lower())
    return candidate


def comment_text(text, limit=60):
    """``text`` for a comment: letters, digits, spaces and ``_.,:=+-``, at most ``limit``.

    No character that could end a C or Structured Text comment (``*``, ``/``,
    parentheses, braces) or start a line survives; the others become ``_``.
    """
    safe = re.sub(r"[^A-Za-z0-9 _.,:=+\-]", "_", str(text))
    return safe if len(safe) <= limit else safe[: limit - 3] + "..."


def _unit(name):
    """The unit an input's name says (greyml's naming), or that of the training data."""
    lowered = str(name).lower()
    for ending, unit in (("_c", "degC"), ("_um", "um"), ("_mm", "mm"), ("rpm", "rpm")):
        if lowered.endswith(ending):
            return unit
    return "as in training"


@dataclass(frozen=True)
class Input:
    """One input: its name in the model, its identifier in generated code, its unit."""

    name: str
    identifier: str
    comment: str
    unit: str


@dataclass(frozen=True)
class Term:
    """One term of the sum: ``weight · lag_tau(x[input] ** power)``."""

    input: int
    power: float
    tau_s: float | None
    weight: float
    idle: bool
    fractional: bool


@dataclass(frozen=True)
class StateVar:
    """One variable of the running state (C struct member, Structured Text variable)."""

    name: str
    kind: str  # "real", "int" or "bool"
    length: int  # 1 for a scalar
    unit: str
    meaning: str


@dataclass(frozen=True)
class Trust:
    """The probe filter's calibration (an :class:`~greyml.controller.Uncertainty`) and constants.

    ``reading_var`` (``scale·noise_var + probe_noise_um²``, the variance of a
    reading's white part) and ``white_var`` (``scale·noise_var``, what no
    reading removes) are computed here as Python computes them, and
    ``glr_threshold`` is the χ²₁ quantile of ``false_alarm_rate / (2·window)``,
    times the uncertainty's ``glr_scale``
    (:func:`greyml.dynamic._observer.glr_threshold`): the exports write the
    numbers, not the arithmetic.
    """

    offset_var: float
    growth_var_per_h: float
    noise_var: float
    memory_var: float
    memory_h: float
    bias_var_per_h: float
    rate_var_per_h3: float
    scale: float
    interval_quantile: float
    probe_noise_um: float
    reading_var: float
    white_var: float
    false_alarm_rate: float
    glr_threshold: float
    window: int
    history: int


@dataclass(frozen=True)
class Envelope:
    """The input envelope (:class:`~greyml.dynamic.InputEnvelope`): per enveloped input,
    its position among the inputs, its range and its largest rate of change per hour."""

    input: tuple
    low: tuple
    high: tuple
    max_rate_per_h: tuple
    rate_slack: float
    #: each term's enveloped input (its position in ``input``), -1 for none
    term_slot: tuple

    def lines(self, inputs, structured_text=False):
        """The header's lines: what training saw of each input, and how to read the flag
        (named as the C state or the Structured Text outputs name it)."""
        out = [
            "Envelope (what training saw; outside it the half-width widens by the model's "
            "response to the excess):"
        ]
        for j, lo, hi, rate in zip(self.input, self.low, self.high, self.max_rate_per_h):
            v = inputs[j]
            out.append(
                f"  {j:3d}  {v.identifier:<32s} [{lo:.6g}, {hi:.6g}] {v.unit}, at most "
                f"{rate:.6g} per hour"
            )
        flag, excess, widening = ("outside", "ex", "widening_um")
        if structured_text:
            flag, excess, widening = ("Outside", "st_ex", "WideningUm")
        out.append(
            f"{flag}: 0 inside the envelope; else 1 + the position (above) of the first "
            f"input outside it at the last row; {excess} holds each enveloped input's excess "
            f"(the input minus its follower, in its own unit), {widening} what the "
            "half-width adds."
        )
        return out


@dataclass(frozen=True)
class Program:
    """Everything an export writes: numbers, policies, state layout and safe names."""

    name: str
    description: str
    inputs: tuple
    terms: tuple
    n_lags: int
    intercept: float
    relative_to_start: bool
    nominal_step_s: float | None
    max_step_s: float | None
    clamp_um: float | None
    quantum_um: float | None
    rate_limit_um_s: float | None
    hold: bool
    max_correction_um: float
    tolerance_um: float | None
    trust: Trust | None
    state: tuple
    greyml_version: str
    envelope: Envelope | None = None

    @property
    def reference(self):
        """Which displacement the output is, in words."""
        if self.relative_to_start:
            return (
                "the change since the first row after init or reset (or since the "
                "displacement given to reset)"
            )
        return (
            "the model's own zero, as fitted (reset with an initial displacement moves it "
            "to the measured value at the next row)"
        )

    @property
    def time_step(self):
        """What the export assumes of the rows' clock, in words."""
        bound = "any length" if self.max_step_s is None else f"at most {self.max_step_s:g} s"
        words = f"time_s in seconds; steps > 0 of {bound} (exact for inputs held between rows)"
        if self.nominal_step_s is not None:
            words += f"; a clock that restarts steps by {self.nominal_step_s:g} s"
        return words

    def limits_text(self):
        parts = [
            "clamp " + ("none" if self.clamp_um is None else f"+-{self.clamp_um:g} um"),
            "quantum " + ("none" if self.quantum_um is None else f"{self.quantum_um:g} um"),
            "rate limit "
            + ("none" if self.rate_limit_um_s is None else f"{self.rate_limit_um_s:g} um/s"),
            "missing input: " + ("hold the last output" if self.hold else "refuse the row"),
        ]
        return "; ".join(parts)

    def to_dict(self):
        """The JSON export (strict JSON: no NaN or infinity)."""
        out = self._dict()
        if self.envelope is not None:  # (a compensator without one exports as before)
            e = self.envelope
            out["envelope"] = {
                "inputs": list(e.input),
                "low": list(e.low),
                "high": list(e.high),
                "max_rate_per_h": list(e.max_rate_per_h),
                "rate_slack": e.rate_slack,
                "term_slot": list(e.term_slot),
            }
            out["algorithm"] = [*out["algorithm"], ENVELOPE_ALGORITHM]
        return out

    def _dict(self):
        trust = None
        if self.trust is not None:
            trust = {k: _bound(getattr(self.trust, k)) for k in self.trust.__dataclass_fields__}
            trust["change_kinds"] = dict(CHANGE_KINDS)
        return {
            "schema": SCHEMA,
            "schema_version": SCHEMA_VERSION,
            "greyml_version": self.greyml_version,
            "name": self.name,
            "model": self.description,
            "reference": self.reference,
            "units": {"time": "s", "output": "um", "rate": "um/s", "tau": "s"},
            "time_step": self.time_step,
            "inputs": [
                {"index": j, "name": v.name, "identifier": v.identifier, "unit": v.unit}
                for j, v in enumerate(self.inputs)
            ],
            "terms": [
                {
                    "input": t.input,
                    "power": t.power,
                    "tau_s": t.tau_s,
                    "weight": t.weight,
                    "idle": t.idle,
                }
                for t in self.terms
            ],
            "intercept": self.intercept,
            "relative_to_start": self.relative_to_start,
            "nominal_step_s": self.nominal_step_s,
            "max_step_s": self.max_step_s,
            "limits": {
                "clamp_um": self.clamp_um,
                "quantum_um": self.quantum_um,
                "rate_limit_um_s": self.rate_limit_um_s,
                "on_missing": "hold" if self.hold else "raise",
                "quanta_max": QUANTA_MAX,
                "quantum_tolerance": QUANTUM_TOLERANCE,
            },
            "max_correction_um": _bound(self.max_correction_um),
            "tolerance_um": _bound(self.tolerance_um),
            "probe_filter": trust,
            "status_codes": {k: {"code": c, "meaning": m} for k, (c, m) in STATUS_CODES.items()},
            "state": [
                {
                    "name": v.name,
                    "type": v.kind,
                    "length": v.length,
                    "unit": v.unit,
                    "meaning": v.meaning,
                }
                for v in self.state
            ],
            "algorithm": ALGORITHM,
        }


def _bound(value):
    """A number for JSON: None (null) for no bound or an infinite one."""
    return None if value is None or math.isinf(value) else value


#: The computation in words, step by step (the JSON carries it; C and ST spell it out).
ALGORITHM = [
    "init: every state variable 0 (false); the output is 0.",
    "reset(initial?): forget the lags, the start, the probe filter and the credit; keep "
    "the output; remember the initial displacement if given.",
    "update(time_s, x): (1) a term with a fractional power whose input is negative -> "
    "refuse(); (2) after the first row: dt = time_s - previous; if not dt > 0: with "
    "nominal_step_s, dt = nominal_step_s and the clock shifts by previous + dt - time_s, "
    "else ERR_TIME; if dt > max_step_s: ERR_GAP; before it: time_s not finite -> ERR_TIME; "
    "(3) an input not finite -> refuse(); (4) v_k = x[input_k] ** power_k; at the first "
    "row lag_k = v_k (0 for idle lags), else lag_k = (1 - a_k) v_k + a_k lag_k with "
    "a_k = exp(-dt / tau_k) (a_k = 0 without lag); total = sum weight_k lag_k; not finite "
    "-> ERR_VALUE (the sum term after term, in the order of terms); (5) at the first row "
    "start = intercept + total - initial (initial given), total (relative_to_start) or "
    "nothing; total -= start; (6) model = intercept + total; the probe filter's "
    "correction: model + offset exp(-dh / memory_h) + bias + rate dh once a reading was "
    "taken (dh in hours since the filter's time); not finite or beyond "
    "max_correction_um -> ERR_VALUE; nothing is kept before this check; (7) the "
    "output stage: clamp, quantise (floor(|v| / q + 0.5) quanta, at most quanta_max, "
    "sign of v), rate limit (without a quantum: within +-rate dt of the last output, 0 "
    "at the first row after init or reset; with one: credit = min(credit + rate dt, "
    "max(rate dt, q)), move floor(min(|target - last|, credit / q + quantum_tolerance)) "
    "quanta towards the target, credit -= moved).",
    "refuse(): time_s not finite -> ERR_TIME; an input not finite -> HELD (the last "
    "output, no state changed; on_missing='hold') or ERR_VALUE; else ERR_VALUE.",
    "observe(time_s, measured): Compensator.observe's Kalman filter (Kalman, 1960) on the "
    "states x = (offset, bias, rate per hour), read through H = (1, 1, 0): the model's "
    "correction m at time_s interpolated from the last `history` rows; dh = max(0, "
    "time_s - filter's time) / 3600, phi = exp(-dh / memory_h), F = [[phi, 0, 0], [0, 1, "
    "dh], [0, 0, 1]], Q = scale [[memory_var (1 - phi^2), 0, 0], [0, bias_var_per_h dh + "
    "rate_var_per_h3 dh^3 / 3, rate_var_per_h3 dh^2 / 2], [0, rate_var_per_h3 dh^2 / 2, "
    "rate_var_per_h3 dh]]; x = F x, P = F P F' + Q, but at the first reading since reset "
    "x = 0, P = diag(scale (offset_var + growth_var_per_h dh), 0, 0); innovation = "
    "(measured - m) - H x, S = H P H' + reading_var, K = P H' / S, x += K innovation, P = "
    "(I - K H) P (I - K H)' + K K' reading_var, symmetrised; the filter, the bank and "
    "the correction are computed on copies and kept only if every number is finite "
    "(else ERR_READING).",
    "the change detector (Willsky and Jones, 1976), after each reading at time_h = time_s "
    "/ 3600: a bank of `window` onsets for each kind (step, ramp) shifts by one (the "
    "newest onset begins at the filter's previous time, the oldest beyond the window "
    "closes); each open onset's response d = F d, its signature g = (0, 1, 0) for a step "
    "or (0, time_h - onset_h, 1) for a ramp, rho = H (g - d), d += rho K, a += rho "
    "innovation / S, b += rho^2 / S; the statistic a^2 / b (0 where b = 0, and for the "
    "ramp of the newest onset, whose statistic is the step's), its largest "
    "(the first, kind by kind and onset by onset, newest first) fires above glr_threshold: "
    "miss = g - d, x += (a / b) miss, P += miss miss' / b, symmetrised, the bank emptied, "
    "changes += 1, change_kind and change_start_s (the onset, s) set; the last "
    "standardised innovation innovation / sqrt(S) is kept.",
    "recalibrate(size?): P += diag(0, size^2, size^2) (size by default sqrt(offset_var + "
    "noise_var), 1 if that is 0; a size not finite or beyond max_correction_um, or a P "
    "that would not be finite: ERR_READING), changes += 1, the bank emptied.",
    "half-width: interval_quantile sqrt(offset_var + growth_var_per_h dh + noise_var) "
    "before any reading (dh from the filter's time to the last row), else "
    "interval_quantile sqrt(max(hph + scale hqh, 0) + white_var) (infinite for NaN) with "
    "phi = exp(-dh / "
    "memory_h), hph = phi phi P00 + P11 + dh dh P22 + 2 (phi P01 + phi dh P02 + dh P12), "
    "hqh = memory_var (1 - phi phi) + bias_var_per_h dh + rate_var_per_h3 dh^3 / 3.",
]


#: What the envelope adds to update (the JSON carries it with an envelope).
ENVELOPE_ALGORITHM = (
    "envelope (in update, after (4), before the state is written): for each enveloped "
    "input i (position input_i): reach = max_rate_per_h_i (dt / 3600) (1 + rate_slack); "
    "f_i = x[input_i] clipped to [max(ef_i - reach, low_i), min(ef_i + reach, high_i)] "
    "([low_i, high_i] at the first row); ex_i = x[input_i] - f_i; xt = x with xt[input_i] "
    "= f_i; e_k = v_k - xt[input_k] ** power_k; elag_k as lag_k with e_k for v_k; d_i = "
    "sum of weight_k elag_k over the terms of input i (term_slot_k = i); at the first row "
    "estart_i = d_i when start is subtracted; d_i -= estart_i; widening_um = sum |d_i|; "
    "outside = 1 + input_i of the first i with ex_i != 0, else 0. half_width = quantile "
    "sqrt(variance) + widening_um."
)

#: State variables that are arrays whatever their length.
ARRAYS = ("lag", "ef", "ex", "elag", "estart")


def _state_layout(n_inputs, n_terms, trust, n_envelope=0):
    """The running state, in the order the C struct and the ST variables declare it."""
    rows = [
        ("started", "bool", 1, "", "a row was taken since init or reset"),
        ("time_s", "real", 1, "s", "time of the last row taken"),
        ("lag", "real", n_terms, "as the term", "each term's lag (its input's power without lag)"),
        ("has_start", "bool", 1, "", "start is subtracted"),
        ("start", "real", 1, "um", "subtracted from the sum of the terms"),
        ("has_initial", "bool", 1, "", "reset was given a displacement"),
        ("initial", "real", 1, "um", "the displacement given to reset"),
        ("model_um", "real", 1, "um", "the model's correction at the last row"),
        ("correction_um", "real", 1, "um", "the correction with probe readings"),
        ("output_um", "real", 1, "um", "the last output (what the axis has)"),
        ("last", "real", 1, "quanta or um", "the last output in the stage's unit"),
        ("credit_um", "real", 1, "um", "what the rate limit still allows (with a quantum)"),
        ("held", "bool", 1, "", "the last row was held for a missing input"),
    ]
    if trust is not None:
        rows += [
            ("has_ft0", "bool", 1, "", "the filter has a time"),
            ("ft0", "real", 1, "s", "the filter's time"),
            ("fx", "real", 3, "um, um, um/h", "offset, bias and bias rate"),
            ("fp", "real", 9, "", "their covariance, row by row"),
            ("adjusted", "bool", 1, "", "a reading was taken"),
            (
                "glr_d",
                "real",
                2 * trust.window * 3,
                "",
                "each kind's and onset's filter response to a unit change, [kind][onset][state]",
            ),
            ("glr_a", "real", 2 * trust.window, "", "sum of rho innovation / S, [kind][onset]"),
            ("glr_b", "real", 2 * trust.window, "", "sum of rho^2 / S, [kind][onset]"),
            ("glr_t0", "real", trust.window, "h", "each onset's start time"),
            ("glr_n", "int", 1, "", "how many onsets are open"),
            ("changes", "int", 1, "", "how many times the change detector fired or recalibrate"),
            ("change_kind", "int", 1, "", "the last change found: 0 none, 1 step, 2 ramp"),
            ("change_start_s", "real", 1, "s", "when it began (0 before one is found)"),
            ("innovation", "real", 1, "", "the last standardised innovation (0 before a reading)"),
            ("has_reading", "bool", 1, "", "a reading was taken since reset"),
            ("last_reading", "real", 1, "s", "time of the last reading"),
            ("ht", "real", trust.history, "s", "times of the rows remembered (a ring)"),
            ("hm", "real", trust.history, "um", "the model's correction at those rows"),
            ("hpos", "int", 1, "", "where the next row is written in the ring"),
            ("hcount", "int", 1, "", "how many rows the ring holds"),
        ]
    if n_envelope:
        rows += [
            ("ef", "real", n_envelope, "as the input", "each enveloped input's follower"),
            ("ex", "real", n_envelope, "as the input", "each one's excess at the last row"),
            ("elag", "real", n_terms, "as the term", "each term's lag of the excess"),
            ("has_estart", "bool", 1, "", "estart is subtracted"),
            ("estart", "real", n_envelope, "um", "each input's response at the first row"),
            ("widening_um", "real", 1, "um", "the half-width's widening at the last row"),
            ("outside", "int", 1, "", "0 inside, else 1 + the first input outside"),
        ]
    return tuple(StateVar(*row) for row in rows)


def describe(comp, *, name="greyml_compensator", description=None):
    """The :class:`Program` of a Compensator (its parameters checked, its plan made anew).

    Parameters
    ----------
    comp : Compensator
    name : str
        The function (C) and function block (Structured Text) name.
    description : str, optional
        The model, in words, for the header comment (sanitised).

    Returns
    -------
    Program
    """
    from greyml import __version__

    name = check_name(name)
    plan = comp.update_plan()
    taken = {name.lower()}
    inputs = tuple(
        Input(v, identifier(v, taken), comment_text(v, 40), _unit(v)) for v in plan.names
    )
    start, stop = plan.span
    n = plan.weight.size
    n_lags = plan.tau.size
    terms = []
    for k in range(n):
        power = float(plan.power[k - start]) if start <= k < stop else 1.0
        terms.append(
            Term(
                input=int(plan.index[k]) - 1,
                power=power,
                tau_s=float(plan.tau[k]) if k < n_lags else None,
                weight=float(plan.weight[k]),
                idle=bool(plan.idle[k]) if k < n_lags else False,
                fractional=power != round(power),
            )
        )
    u = plan.uncertainty
    trust = None
    if u is not None:
        probe_noise = float(comp.probe_noise_um)
        rate = float(comp.false_alarm_rate)
        trust = Trust(
            u.offset_var,
            u.growth_var_per_h,
            u.noise_var,
            u.memory_var,
            u.memory_h,
            u.bias_var_per_h,
            u.rate_var_per_h3,
            u.scale,
            interval_quantile=float(comp.interval_quantile),
            probe_noise_um=probe_noise,
            # as Compensator.observe and status compute them
            reading_var=u.scale * u.noise_var + probe_noise * probe_noise,
            white_var=u.scale * u.noise_var,
            false_alarm_rate=rate,
            glr_threshold=glr_threshold(rate) * u.glr_scale,  # as observe compares it
            window=WINDOW,
            history=HISTORY,
        )
    envelope = None
    if plan.envelope is not None:
        e = plan.envelope
        slot_of = {int(position): i for i, position in enumerate(e.take)}
        envelope = Envelope(
            input=tuple(int(j) - 1 for j in e.take),
            low=tuple(float(v) for v in e.low),
            high=tuple(float(v) for v in e.high),
            max_rate_per_h=tuple(float(v) for v in e.max_rate_per_h),
            rate_slack=RATE_SLACK,
            term_slot=tuple(slot_of.get(int(position), -1) for position in plan.index),
        )
    limits = plan.limits
    clamp, quantum, rate = limits.clamp_um, limits.quantum_um, limits.rate_limit_um_s
    max_step = plan.max_step
    if description is None:
        description = f"Compensator of {n} terms over {len(inputs)} inputs"
    return Program(
        name=name,
        description=comment_text(description, 100),
        inputs=inputs,
        terms=tuple(terms),
        n_lags=n_lags,
        intercept=float(comp.intercept),
        relative_to_start=bool(comp.relative_to_start),
        nominal_step_s=None if comp.nominal_step_s is None else float(comp.nominal_step_s),
        max_step_s=None if math.isinf(max_step) else float(max_step),
        clamp_um=clamp,
        quantum_um=quantum,
        rate_limit_um_s=rate,
        hold=comp.on_missing == "hold",
        max_correction_um=float(comp.max_correction_um),
        tolerance_um=None if comp.tolerance_um is None else float(comp.tolerance_um),
        trust=trust,
        state=_state_layout(len(inputs), n, trust, 0 if envelope is None else len(envelope.input)),
        greyml_version=comment_text(__version__, 30),
        envelope=envelope,
    )
