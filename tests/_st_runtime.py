"""IEC 61131-3 Structured Text run in Python: the subset greyml's export writes (tests only).

A third-party parser, blark (SLAC's TwinCAT 3 grammar), reads the source; this
module translates its syntax tree, statement by statement, into a Python
function over a dict of variables and runs it. Only what the export emits is
understood (LREAL, DINT, BOOL and arrays of them; assignments, IF, FOR;
+ - * / MOD, comparisons, AND OR NOT; ABS, EXP, EXPT, SQRT, TRUNC,
DINT_TO_LREAL): anything else is an error, so an export that strays from the
subset fails its test instead of being run wrongly. LREAL is Python's float
(IEEE 754 binary64, as a PLC's LREAL); division and the functions follow IEEE
754 (infinity and NaN, no exception); DINT is checked to stay within 32 bits;
array indices are checked against the declared bounds.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import json
import math
import os
from pathlib import Path

import blark
import blark.transform as tf
from blark import parse_source_code

__all__ = ["FunctionBlock"]

_DINT = 2**31


def _dint(value):
    if isinstance(value, bool) or not isinstance(value, int) or not -_DINT <= value < _DINT:
        raise ArithmeticError(f"not a DINT: {value!r}")
    return value


def _lreal(value):
    if isinstance(value, bool):
        raise TypeError("a BOOL assigned to an LREAL")
    return float(value)


def _bool(value):
    if not isinstance(value, bool):
        raise TypeError(f"not a BOOL: {value!r}")
    return value


_COERCE = {"LREAL": _lreal, "DINT": _dint, "BOOL": _bool}
_ZERO = {"LREAL": 0.0, "DINT": 0, "BOOL": False}


def _div(a, b):
    if isinstance(a, int) and isinstance(b, int) and not isinstance(a, bool):
        raise TypeError("integer division is not in the subset")
    a, b = float(a), float(b)
    if b == 0.0:
        if a == 0.0 or math.isnan(a):
            return math.nan
        return math.copysign(math.inf, a) * math.copysign(1.0, b)
    return a / b


def _exp(x):
    try:
        return math.exp(x)
    except OverflowError:
        return math.inf


def _expt(x, p):
    try:
        return math.pow(x, p)
    except OverflowError:
        return math.inf
    except ValueError:  # a negative number to a fractional power
        return math.nan


def _sqrt(x):
    return math.sqrt(x) if x >= 0 else math.nan


def _trunc(x):
    if not math.isfinite(x):
        raise ArithmeticError(f"TRUNC of {x!r}")
    return _dint(int(x))


def _mod(a, b):
    _dint(a), _dint(b)
    if a < 0 or b <= 0:
        raise ArithmeticError("MOD of a negative number is not in the subset")
    return a % b


def _at(array, index):
    if not (isinstance(index, int) and 0 <= index < len(array)):
        raise IndexError(f"index {index!r} out of ARRAY[0..{len(array) - 1}]")
    return index


_FUNCTIONS = {
    "ABS": "abs",
    "EXP": "_exp",
    "EXPT": "_expt",
    "SQRT": "_sqrt",
    "TRUNC": "_trunc",
    "DINT_TO_LREAL": "float",
}
_OPERATORS = {
    "+": "+",
    "-": "-",
    "*": "*",
    "<": "<",
    ">": ">",
    "<=": "<=",
    ">=": ">=",
    "=": "==",
    "<>": "!=",
    "AND": "&",  # both sides evaluated, as on a PLC
    "OR": "|",
}


class FunctionBlock:
    """One instance of the ``FUNCTION_BLOCK`` in ``source``; call it with its inputs.

    Parameters
    ----------
    source : str
        Structured Text holding one function block.
    cache : path-like, optional
        A folder where the translation of each source is kept (by its SHA-256,
        blark's version and this module's), so that processes that run the same
        block parse it once between them (blark's parse takes 5-25 s).

    Attributes
    ----------
    name : str
    variables : dict
        Every variable by its lower-case name (Structured Text ignores case).
    """

    def __init__(self, source, cache=None):
        translated = _translate(source, None if cache is None else os.fspath(cache))
        self.name, self.types, self.inputs, self.outputs, self._run = translated[:5]
        self.variables = {
            k: list(v) if isinstance(v, list) else v for k, v in translated[5].items()
        }

    def __call__(self, **inputs):
        """Set the inputs named (case ignored; the others keep their values), run the
        body once, and return the outputs by lower-case name."""
        for key, value in inputs.items():
            name = key.lower()
            if name not in self.inputs:
                raise KeyError(f"{key} is not an input of {self.name}")
            self.variables[name] = _COERCE[self.types[name]](value)
        self._run(self.variables)
        return {name: self.variables[name] for name in self.outputs}


@functools.lru_cache(maxsize=16)
def _translate(source, cache=None):
    """The block's name, types, inputs, outputs, body and initial values (blark parses
    a block of a few hundred lines in seconds: each source is parsed once a process,
    and once between processes that share a ``cache`` folder)."""
    if cache is None:
        t = _Translator(source)
        return t.name, t.types, t.inputs, t.outputs, t.run, t.variables
    key = hashlib.sha256(
        "\0".join((source, blark.__version__, Path(__file__).read_text())).encode()
    ).hexdigest()
    folder = Path(cache)
    folder.mkdir(parents=True, exist_ok=True)
    stored = folder / f"{key}.json"
    with open(folder / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another process parsing it: wait for it
        if stored.exists():
            saved = json.loads(stored.read_text())
        else:
            t = _Translator(source)
            saved = {
                "name": t.name,
                "types": t.types,
                "inputs": t.inputs,
                "outputs": t.outputs,
                "code": t.code,
                "variables": t.variables,
            }
            temporary = folder / f"{key}.{os.getpid()}.tmp"
            temporary.write_text(json.dumps(saved))
            temporary.replace(stored)
    return (
        saved["name"],
        saved["types"],
        saved["inputs"],
        saved["outputs"],
        _compiled(saved["name"], saved["code"]),
        saved["variables"],
    )


def _compiled(name, code):
    """The body's Python code as a function ``run(V)``."""
    namespace = {
        "_div": _div,
        "_exp": _exp,
        "_expt": _expt,
        "_sqrt": _sqrt,
        "_trunc": _trunc,
        "_mod": _mod,
        "_at": _at,
        "_lreal": _lreal,
        "_dint": _dint,
        "_bool": _bool,
    }
    exec(compile(code, f"<{name}>", "exec"), namespace)
    return namespace["run"]


class _Translator:
    """blark's syntax tree of one function block, as a Python function."""

    def __init__(self, source):
        parsed = parse_source_code(source)
        if parsed.exception is not None:
            raise parsed.exception
        blocks = [i for i in parsed.transform().items if isinstance(i, tf.FunctionBlock)]
        if len(blocks) != 1:
            raise ValueError(f"expected one FUNCTION_BLOCK, found {len(blocks)}")
        block = blocks[0]
        self.name = str(block.name)
        self.types, self.variables, self.inputs, self.outputs = {}, {}, [], []
        for section in block.declarations:
            for item in section.items:
                self._declare(section, item)
        lines = ["def run(V):"]
        self._statements(block.body.statements, lines, 1)
        self.code = "\n".join(lines)
        self.run = _compiled(self.name, self.code)

    # -- declarations ----------------------------------------------------------

    def _declare(self, section, item):
        init = item.init
        if isinstance(init, tf.ArrayTypeInitialization):
            (subrange,) = init.spec.subranges
            low, high = self._constant(subrange.start), self._constant(subrange.stop)
            if low != 0:
                raise ValueError("arrays start at 0 in the subset")
            kind = str(init.spec.type)
            values = [_ZERO[kind]] * (high + 1)
            if init.value is not None:
                elements = [self._constant(e) for e in self._elements(init.value)]
                if len(elements) != len(values):
                    raise ValueError(f"{len(elements)} initial values for {len(values)} elements")
                values = [_COERCE[kind](v) for v in elements]
        elif isinstance(init, tf.TypeInitialization):
            kind = str(init.spec.type if hasattr(init.spec, "type") else init.spec)
            values = (
                _ZERO[kind] if init.value is None else _COERCE[kind](self._constant(init.value))
            )
        else:
            raise ValueError(f"declaration {type(init).__name__} is not in the subset")
        if kind not in _COERCE:
            raise ValueError(f"type {kind} is not in the subset")
        for variable in item.variables:
            name = str(variable.name).lower()
            if name in self.types:
                raise ValueError(f"{name} declared twice")
            self.types[name] = kind
            self.variables[name] = list(values) if isinstance(values, list) else values
            if isinstance(section, tf.InputDeclarations):
                self.inputs.append(name)
            elif isinstance(section, tf.OutputDeclarations):
                self.outputs.append(name)

    def _elements(self, initialization):
        """The elements of ``[a, b, c]`` in order (blark nests all but the first)."""
        out = []
        for e in initialization.elements:
            if e.count is not None:
                raise ValueError("repeated array elements are not in the subset")
            if isinstance(e.element, tf.ArrayInitialization):
                out += self._elements(e.element)
            else:
                out.append(e.element)
        return out

    def _constant(self, node):
        if isinstance(node, tf.Real):
            return float(str(node.value))
        if isinstance(node, tf.Integer):
            return int(str(node.value))
        if isinstance(node, tf.Boolean):
            return str(node.value).upper() == "TRUE"
        if isinstance(node, tf.UnaryOperation) and str(node.op) == "-":
            return -self._constant(node.expr)
        raise ValueError(f"constant {node} is not in the subset")

    # -- statements and expressions ---------------------------------------------

    def _statements(self, statements, lines, depth):
        pad = "    " * depth
        if not statements:
            lines.append(pad + "pass")
        for st in statements:
            if isinstance(st, tf.AssignmentStatement):
                (target,) = st.variables
                name, index = self._target(target)
                value = f"{self._coerce(name)}({self._expr(st.expression)})"
                if index is None:
                    lines.append(f"{pad}V[{name!r}] = {value}")
                else:
                    lines.append(f"{pad}V[{name!r}][_at(V[{name!r}], {index})] = {value}")
            elif isinstance(st, tf.IfStatement):
                lines.append(f"{pad}if _bool({self._expr(st.if_expression)}):")
                self._statements(st.statements.statements, lines, depth + 1)
                for clause in st.else_ifs:
                    lines.append(f"{pad}elif _bool({self._expr(clause.if_expression)}):")
                    self._statements(clause.statements.statements, lines, depth + 1)
                if st.else_clause is not None:
                    lines.append(f"{pad}else:")
                    self._statements(st.else_clause.statements.statements, lines, depth + 1)
            elif isinstance(st, tf.ForStatement):
                if st.step is not None:
                    raise ValueError("FOR ... BY is not in the subset")
                name, index = self._target(st.control)
                if index is not None or self.types[name] != "DINT":
                    raise ValueError("a FOR loop counts a DINT variable")
                start, stop = self._expr(st.from_), self._expr(st.to)
                lines.append(f"{pad}for _i in range(_dint({start}), _dint({stop}) + 1):")
                lines.append(f"{pad}    V[{name!r}] = _i")
                self._statements(st.statements.statements, lines, depth + 1)
            else:
                raise ValueError(f"statement {type(st).__name__} is not in the subset: {st}")

    def _target(self, node):
        if isinstance(node, tf.SimpleVariable):
            name = str(node.name).lower()
            index = None
        elif isinstance(node, tf.MultiElementVariable):
            name = str(node.name.name if hasattr(node.name, "name") else node.name).lower()
            (elements,) = node.elements
            (subscript,) = elements.subscripts
            index = self._expr(subscript)
        else:
            raise ValueError(f"variable {node} is not in the subset")
        if name not in self.types:
            raise ValueError(f"{name} is not declared")
        return name, index

    def _coerce(self, name):
        return {"LREAL": "_lreal", "DINT": "_dint", "BOOL": "_bool"}[self.types[name]]

    def _expr(self, node):
        if isinstance(node, (tf.Real, tf.Integer, tf.Boolean)):
            return repr(self._constant(node))
        if isinstance(node, (tf.SimpleVariable, tf.MultiElementVariable)):
            name, index = self._target(node)
            return f"V[{name!r}]" if index is None else f"V[{name!r}][_at(V[{name!r}], {index})]"
        if isinstance(node, tf.ParenthesizedExpression):
            return f"({self._expr(node.expr)})"
        if isinstance(node, tf.UnaryOperation):
            op = str(node.op).upper()
            if op == "-":
                return f"(-{self._expr(node.expr)})"
            if op == "NOT":
                return f"(not _bool({self._expr(node.expr)}))"
        if isinstance(node, tf.BinaryOperation):
            op = str(node.op).upper()
            left, right = self._expr(node.left), self._expr(node.right)
            if op == "/":
                return f"_div({left}, {right})"
            if op == "MOD":
                return f"_mod({left}, {right})"
            if op in ("AND", "OR"):
                return f"(_bool({left}) {_OPERATORS[op]} _bool({right}))"
            if op in _OPERATORS:
                return f"({left} {_OPERATORS[op]} {right})"
        if isinstance(node, tf.FunctionCall):
            name = str(node.name.name if hasattr(node.name, "name") else node.name).upper()
            if name in _FUNCTIONS:
                args = []
                for parameter in node.parameters:
                    if getattr(parameter, "name", None) is not None:
                        raise ValueError("named parameters are not in the subset")
                    args.append(self._expr(parameter.value))
                return f"{_FUNCTIONS[name]}({', '.join(args)})"
        raise ValueError(f"expression {node} ({type(node).__name__}) is not in the subset")
