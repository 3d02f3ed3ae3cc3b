"""``greyml export``: a saved compensator or transfer function as C, Structured Text or JSON."""

from __future__ import annotations

import os

from greyml._cli import _flags as flags
from greyml._cli._files import (
    STDOUT,
    _check_output_file,
    _load_model_file,
    _output_name,
    _write_stdout,
)
from greyml._cli._printing import _progress, _warn, printable

_EXPORT_EPILOG = """\
MODEL.file is a Compensator saved with greyml.persist.save_model, or a model
written by greyml fit --model transfer-function (its compensator is exported,
with its calibration: the C file and the function block then take probe
readings too). FILE is a C99 file (c), an IEC 61131-3 Structured Text function
block for TwinCAT 3 or CODESYS (st), or JSON of the coefficients, limits and
state layout (json); each starts with the model, the inputs in order with their
units, the reference, the time step and the greyml version. The limits given
here replace the compensator's own. Names from the model file reach the code
only as identifiers of letters, digits and underscores. FILE is written to a
temporary name and renamed (complete or absent); an existing FILE is replaced
only with --force. The export is not safety-certified: validate it on the
machine (greyml's docs, "Export to a controller").

Examples:
  greyml fit caiviac.csv --target ch1_um --model transfer-function \\
      --drivers spindle_rpm --max-sensors 5 --test-column cycle --out ch1.greyml
  greyml export ch1.greyml --language st --out ch1_comp.st --name ch1_comp \\
      --rate-limit 0.5 --quantum 0.1 --clamp 100
  greyml export ch1.greyml --language c --out ch1_comp.c --name ch1_comp --tolerance 5
  greyml export ch1.greyml --language json --out ch1_comp.json
"""

#: The languages of --language (as Compensator.export takes them).
LANGUAGES = ("c", "st", "json")


def _add_export_parser(subparsers):
    parser = flags._subparser(subparsers, "export", _EXPORT_EPILOG)
    parser.add_argument("model", metavar="MODEL.file", help="compensator or transfer function")
    parser.add_argument("--language", required=True, choices=LANGUAGES, help="what to write")
    parser.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="file to write; - writes it to standard output and what export prints to "
        "standard error",
    )
    parser.add_argument("--force", action="store_true", help="replace FILE if it exists")
    parser.add_argument(
        "--name",
        default="greyml_compensator",
        metavar="NAME",
        help="the C function prefix and the function block's name (default: greyml_compensator)",
    )
    limits = parser.add_argument_group("the controller's limits (µm, s)")
    for flag, metavar, help_text in (
        ("--rate-limit", "UM_S", "the output changes by at most this many µm per second"),
        ("--quantum", "UM", "the output is a whole number of this many µm, e.g. 0.1"),
        ("--clamp", "UM", "the output stays within ±UM (a whole number of quanta)"),
    ):
        limits.add_argument(flag, type=flags._positive_number, metavar=metavar, help=help_text)
    limits.add_argument(
        "--tolerance",
        type=flags._positive_number,
        metavar="UM",
        help="the correction is trusted (Trusted, <name>_trusted) while its interval's "
        "half-width is at most UM (without it, whenever it is plausible)",
    )
    limits.add_argument(
        "--on-missing",
        choices=("hold", "raise"),
        help="a missing (NaN or infinite) input: hold the last output (the default) or "
        "refuse the row",
    )
    flags._end_options(parser, flags._calls(run_export), reads_csv=False)


def _compensator(model_path):
    """The compensator a model file holds or gives, the model in words, and the
    warnings loading it raised.

    A file that is not a greyml model, or holds neither a compensator nor a
    transfer function, is a ValueError with one line naming the file.
    """
    from greyml.controller import Compensator
    from greyml.dynamic import ThermalTransferFunction

    name = os.fspath(model_path)
    model, caught = _load_model_file(model_path)
    steps = getattr(model, "steps", None)
    final = steps[-1][1] if steps else model
    base = os.path.basename(name)
    if isinstance(final, Compensator):
        return final, f"Compensator from {base}", caught
    if isinstance(final, ThermalTransferFunction):
        comp = Compensator.from_model(final)
        return (
            comp,
            f"ThermalTransferFunction from {base}, reference {final.reference_}",
            caught,
        )
    raise ValueError(
        f"{name!r} holds a {type(final).__name__}; greyml export takes a Compensator or a "
        "transfer function (greyml fit --model transfer-function)."
    )


def run_export(
    model,
    language,
    out,
    *,
    force=False,
    name="greyml_compensator",
    rate_limit=None,
    quantum=None,
    clamp=None,
    tolerance=None,
    on_missing=None,
    quiet=False,
    stdout=None,
):
    """``greyml export``: write a saved compensator as C, Structured Text or JSON.

    Parameters
    ----------
    model : str or path-like
        A Compensator saved with :func:`greyml.persist.save_model`, or a model
        from ``greyml fit --model transfer-function`` (its compensator).
    language : {"c", "st", "json"}
    out : str or path-like
        The file to write; ``"-"``: write it to ``stdout``.
    force : bool, default=False
        Replace ``out`` if it exists.
    name : str, default="greyml_compensator"
        The C function prefix and the function block's name.
    rate_limit, quantum, clamp : float, optional
        ``rate_limit_um_s``, ``quantum_um`` and ``clamp_um`` of the
        compensator (replacing its own).
    tolerance : float, optional
        ``tolerance_um`` of the compensator (replacing its own): the exported
        trust flag is set while the interval's half-width is at most this.
    on_missing : {"hold", "raise"}, optional
        Replaces the compensator's own.
    quiet : bool, default=False
        No progress on standard error.
    stdout : text stream, optional
        The command's standard output, where ``out="-"`` writes the export.

    Returns
    -------
    int
        0.
    """
    path = _check_output_file(out, force)
    with _progress(2, quiet) as progress:
        progress.step(f"reading the model {os.fspath(model)!r}")
        comp, what, caught = _compensator(model)
        given = {
            "rate_limit_um_s": rate_limit,
            "quantum_um": quantum,
            "clamp_um": clamp,
            "tolerance_um": tolerance,
            "on_missing": on_missing,
        }
        comp.set_params(**{k: v for k, v in given.items() if v is not None})
        if path == STDOUT:
            from greyml.controller._export._write import export_text

            progress.step("writing the export to standard output")
            text = export_text(comp, language, name=name, description=what)
            _write_stdout(stdout, text)
            size = len(text.encode("ascii"))
        else:
            progress.step(f"writing {os.fspath(path)!r}")
            comp.export(language, path, name=name, description=what, overwrite=force)
            size = path.stat().st_size
    _warn("export", [str(w.message) for w in caught])
    print(
        f"wrote {_output_name(path)} ({language}, {size:,} bytes): {printable(what)}; "
        f"{len(comp.inputs)} inputs, {len(comp.terms)} terms."
    )
    limits = [
        f"{label}{value:g} µm{unit}"
        for label, value, unit in (
            ("rate limit ", comp.rate_limit_um_s, "/s"),
            ("quantum ", comp.quantum_um, ""),
            ("clamp ±", comp.clamp_um, ""),
        )
        if value is not None
    ]
    trusted = (
        "trusted whenever plausible (no --tolerance)"
        if comp.tolerance_um is None
        else f"trusted while the half-width is at most {comp.tolerance_um:g} µm"
    )
    print(
        f"  limits: {', '.join(limits) or 'none'}; a missing input: "
        f"{'hold the last output' if comp.on_missing == 'hold' else 'refuse the row'}; "
        f"{trusted}"
    )
    return flags.EXIT_OK
