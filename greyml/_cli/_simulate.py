"""``greyml simulate``: simulated heating/cooling tests of a machine, as a CSV file."""

from __future__ import annotations

import os

from greyml._cli import _flags as flags
from greyml._cli._files import (
    STDOUT,
    _check_output_file,
    _csv_text,
    _output_name,
    _test_labels,
    _write_stdout,
)
from greyml._cli._printing import _progress
from greyml._command_names import MACHINES

_SIMULATE_EPILOG = """\
The CSV has the columns test and time_s, then the operating inputs, the sensors
(T<k>_C, FBG<k>_ue) and the displacements (dx_um, dy_um, dz_um); read it with
greyml.io.read_tests_csv.

Tests (default: all the seeds' tests of the machine):
  vmc        Abdulshahed et al.'s (2015) Tests I-VI (76 temperature sensors, every minute)
  vmc-probe  Abdulshahed et al.'s (2017) 200-min probing test (9 sensors, every 10 s)
  gantry     Abdulshahed et al.'s (2016) Z-axis, C-axis and helical tests (12 temperatures and
             7 FBGs, every 20 s)
--tests A,B keeps only these of the seeds' tests.

--programme SPEC simulates a test of your own instead (repeat it for several
tests; they are labelled P1, P2, ...). SPEC is segments separated by commas:
MINUTES alone stops everything (the machine cools); MINUTES:NAME=VALUE runs an
operating input, NAME one of spindle_rpm, feed_mm_min (vmc, vmc-probe, gantry)
or c_rpm (gantry). The air stays at --ambient degrees C.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml simulate --machine vmc --tests IV,V --out vmc-iv-v.csv
  greyml simulate --machine vmc --out mine.csv --random-state 1 \\
      --programme 120:spindle_rpm=4000,60 --programme 60:spindle_rpm=8000,60
  greyml simulate --machine gantry --out c.csv --programme 120:c_rpm=2500,120
"""


def _add_simulate_parser(subparsers):
    parser = flags._subparser(subparsers, "simulate", _SIMULATE_EPILOG)
    parser.add_argument(
        "--machine", required=True, choices=MACHINES, help="the machine to simulate"
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="FILE.csv",
        help="CSV file to write; - writes it to standard output and what simulate prints to "
        "standard error",
    )
    parser.add_argument(
        "--programme",
        action="append",
        metavar="SPEC",
        dest="programmes",
        help="a test of your own, e.g. 120:spindle_rpm=4000,60 (may be repeated)",
    )
    parser.add_argument(
        "--tests",
        metavar="seeds|A,B",
        help="the seeds' tests (default), or only the ones named, e.g. IV,V",
    )
    parser.add_argument(
        "--ambient",
        type=float,
        default=20.0,
        metavar="C",
        help="air temperature in degrees C of --programme tests (default: 20)",
    )
    flags._add_random_state(
        parser,
        "seed of the measurement noise (default: 0, the data of greyml.datasets)",
        dest="seed",
    )
    parser.add_argument("--force", action="store_true", help="replace FILE.csv if it exists")
    flags._end_options(parser, _run_simulate, reads_csv=False)


def _run_simulate(args):
    tests = None
    if args.tests is not None and args.tests.strip() != "seeds":
        tests = flags._unique(flags._names(args.tests))
        if not tests:
            raise ValueError("--tests names no test; write seeds or labels like IV,V.")
    return flags._call(run_simulate, args, tests=tests)


def parse_programme(spec, inputs):
    """A :class:`greyml.simulation.Programme` from a short text.

    Parameters
    ----------
    spec : str
        Segments separated by commas. A segment is ``MINUTES`` (everything
        stopped, the machine cools) or ``MINUTES:NAME=VALUE`` with one or more
        ``:NAME=VALUE`` parts, NAME one of ``inputs``. ``120:spindle_rpm=4000,60``
        runs the spindle at 4000 rpm for 120 min, then stops it for 60 min.
    inputs : sequence of str
        The operating inputs the machine has.

    Returns
    -------
    Programme
    """
    from greyml.simulation import Programme

    programme = Programme(name=spec.strip())
    segments = [s.strip() for s in spec.split(",")]
    if not spec.strip() or any(not s for s in segments):
        raise ValueError(
            f"--programme {spec!r} has an empty segment; write segments like "
            "'120:spindle_rpm=4000,60' separated by commas."
        )
    for segment in segments:
        minutes, *levels = [p.strip() for p in segment.split(":")]
        try:
            minutes = float(minutes)
        except ValueError:
            raise ValueError(
                f"segment {segment!r} of --programme does not start with its length in "
                "minutes (e.g. '120:spindle_rpm=4000' or '60')."
            ) from None
        values = {}
        for level in levels:
            name, value = flags._name_value(
                level,
                inputs,
                f"segment {segment!r} of --programme: {level!r} must be NAME=VALUE with "
                f"NAME one of {', '.join(inputs)} (this machine's inputs).",
            )
            try:
                values[name] = float(value)
            except ValueError:
                raise ValueError(
                    f"segment {segment!r} of --programme: {value.strip()!r} is not a number."
                ) from None
        programme = programme.run(minutes, **values)
    return programme


def run_simulate(
    machine,
    out,
    *,
    programmes=None,
    tests=None,
    ambient=20.0,
    seed=0,
    force=False,
    quiet=False,
    stdout=None,
):
    """``greyml simulate``: write simulated tests of a machine to a CSV file.

    Parameters
    ----------
    machine : {"vmc", "vmc-probe", "gantry"}
    out : str or path-like
        CSV file to write (:func:`greyml.io.write_tests_csv`); ``"-"``: write it
        to ``stdout``.
    programmes : list of str, optional
        Programme specs (:func:`parse_programme`), one test each, labelled
        ``P1``, ``P2``, … Default: the seeds' tests of the machine.
    tests : list of str, optional
        Only these of the seeds' tests (by label); all by default.
    ambient : float, default=20.0
        Constant air temperature (°C) of the ``programmes`` tests.
    seed : int, default=0
        Seed of the measurement noise (``--random-state``). The seeds' tests
        with seed 0 are the data of :func:`greyml.datasets.load_vmc_tests` and
        its siblings.
    force : bool, default=False
        Replace ``out`` if it exists.
    quiet : bool, default=False
        No progress on standard error.
    stdout : text stream, optional
        The command's standard output, where ``out="-"`` writes the CSV.

    Returns
    -------
    int
        0.
    """
    from greyml.datasets import make_tests
    from greyml.io import write_tests_csv
    from greyml.simulation import gantry, vmc

    if machine not in MACHINES:
        raise ValueError(f"unknown machine {machine!r}; choose one of {', '.join(MACHINES)}.")
    path = _check_output_file(out, force)
    if programmes and tests:
        raise ValueError("give --programme or --tests, not both.")
    with _progress(2, quiet) as progress:
        progress.step(f"simulating the {machine}'s tests")
        if programmes:
            preset = (
                gantry()
                if machine == "gantry"
                else vmc("probe" if machine == "vmc-probe" else "ncdt")
            )
            specs = {
                f"P{k + 1}": parse_programme(p, preset.inputs) for k, p in enumerate(programmes)
            }
            data = make_tests(machine, specs, ambient=ambient, random_state=seed)
            frame = data.frame
        else:
            data = make_tests(machine, None, random_state=seed)
            frame = data.frame
            if tests:
                missing = [t for t in tests if t not in data.tests]
                if missing:
                    raise ValueError(
                        f"--tests {', '.join(missing)}: the seeds' tests of the {machine} are "
                        f"{', '.join(data.tests)}."
                    )
                keep = frame.index.get_level_values("test").isin(tests)
                frame = frame[keep]
        if path == STDOUT:
            progress.step("writing the tests to standard output")
            _write_stdout(stdout, _csv_text(frame))
        else:
            progress.step(f"writing {os.fspath(path)!r}")
            write_tests_csv(frame, path, overwrite=force)
    labels = _test_labels(frame)
    print(
        f"wrote {len(frame)} rows of {len(labels)} simulated test(s) of the {machine} "
        f"({', '.join(labels)}) to {_output_name(path)}: columns test, time_s, "
        f"{len(data.inputs)} operating inputs, {len(data.sensors)} sensors, targets "
        f"{', '.join(data.targets)}."
    )
    return 0
