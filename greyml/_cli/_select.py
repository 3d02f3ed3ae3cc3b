"""``greyml select``: the sensors GreyInfluenceSelector keeps, with group and influence."""

from __future__ import annotations

import os

from greyml._cli import _flags as flags
from greyml._cli._files import _load_training, _test_labels
from greyml._cli._fitting import _fit_quietly, _selector
from greyml._cli._printing import _progress, _tests_words, _warn, printable
from greyml._docstrings import shared_doc

_SELECT_EPILOG = """\
DATA.csv has the columns test and time_s, then the data columns (as greyml
simulate writes them). For every candidate sensor, GM(1,N) of the target
gives an influence weight; fuzzy c-means sorts the sensors into --n-sensors
groups and the most influential sensor of each group is kept
(greyml.GreyInfluenceSelector). The sensors are used as they are in the file.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml select vmc.csv --target dy_um --n-sensors 5 --train-tests IV
  greyml select vmc.csv --target dy_um --cluster-on series --sensors T1_C,T2_C,T3_C
  greyml select spreadsheet.csv --target dz_um --time-unit min --sep ';' --decimal ,
"""


def _add_select_parser(subparsers):
    parser = flags._subparser(subparsers, "select", _SELECT_EPILOG)
    parser.add_argument("data", metavar="DATA.csv", help="tests (CSV)")
    flags._add_target(parser)
    parser.add_argument(
        "--n-sensors",
        type=flags._count,
        default=5,
        metavar="N",
        dest="n",
        help="sensors to keep (default: 5)",
    )
    parser.add_argument("--cluster-on", choices=("series", "influence"), help=flags._CLUSTER_HELP)
    flags._add_names(
        parser,
        "--train-tests",
        "select on these tests only (default: all tests)",
    )
    flags._add_names(parser, "--sensors", flags._SENSORS_HELP)
    flags._add_random_state(parser, "seed of the c-means starts (default: 0)")
    flags._end_options(parser, flags._calls(run_select))


@shared_doc(csv_and_quiet=flags._CSV_AND_QUIET_DOC)
def run_select(
    data,
    target,
    *,
    n=5,
    cluster_on=None,
    train_tests=None,
    sensors=None,
    random_state=0,
    csv_options=None,
    quiet=False,
):
    """``greyml select``: the sensors GreyInfluenceSelector keeps, with group and influence.

    Parameters
    ----------
    data : str or path-like
        CSV file of tests (:func:`greyml.io.read_tests_csv`).
    target : str
        Target column (a displacement).
    n : int, default=5
        Sensors to keep (c-means groups; ``--n-sensors``).
    cluster_on : {"series", "influence"}, optional
        GreyInfluenceSelector's default (``"influence"``) when None.
    train_tests : list of str, optional
        Select on these tests only; all tests by default.
    sensors : list of str, optional
        Candidate sensors; by default every column except the target, the
        displacements (``*_um``) and the operating inputs.
    random_state : int, default=0
    {csv_and_quiet}

    Returns
    -------
    int
        0.
    """
    import numpy as np

    with _progress(2, quiet) as progress:
        progress.step(f"reading {os.fspath(data)!r}")
        frame, columns = _load_training(
            data, target, sensors, train_tests, "--train-tests", csv_options
        )
        if n > len(columns):
            raise ValueError(
                f"--n-sensors {n} asks for more sensors than the {len(columns)} candidate(s) "
                f"of {os.fspath(data)!r}."
            )
        selector = _selector(n, cluster_on, random_state)
        cluster_on = selector.cluster_on
        progress.step(f"grouping {len(columns)} sensors with GreyInfluenceSelector")
        _, messages = _fit_quietly(selector, frame[columns], frame[target])
    _warn("select", messages)
    names = list(selector.feature_names_in_)
    tests = _test_labels(frame)
    print(
        f"GreyInfluenceSelector(n_clusters={n}, cluster_on={cluster_on!r}) on "
        f"{_tests_words(tests)} ({len(frame)} rows) of {os.fspath(data)!r}, target "
        f"{printable(target)!r}: "
        f"kept {len(selector.selected_)} of {len(columns)} candidate sensors."
    )
    print(f"  {'rank':>4s}  {'sensor':14s} {'group':>5s} {'influence':>10s}  sensors in the group")
    for rank, name in enumerate(selector.selected_, start=1):
        j = names.index(name)
        group = int(selector.clusters_[j])
        members = [printable(names[i]) for i in np.flatnonzero(selector.clusters_ == group)]
        listed = ", ".join(members[:6]) + (", ..." if len(members) > 6 else "")
        # padded as it is shown: a name's control characters are not printed
        print(
            f"  {rank:4d}  {printable(name):14s} {group + 1:5d} {selector.influence_[j]:10.4g}  "
            f"{len(members)}: {listed}"
        )
    print(
        "Influence: the sensor's GM(1,N) weight on the target (sensors scaled to [0, 1]); "
        "each group keeps its sensor of largest |influence|."
    )
    return 0
