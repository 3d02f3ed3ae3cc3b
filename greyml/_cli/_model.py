"""The model a ``greyml`` command builds from its flags: ``greyml fit`` and ``greyml validate``.

:func:`add_model_flags` adds the flags (``--model``, ``--n-sensors``,
``--drivers``, ``--max-sensors``, the transfer function's settings,
``--sensors``, ``--rises``, ``--random-state``); :class:`ModelChoice` holds
what they ask for, checked before any file is read; :func:`build` makes the
unfitted estimator (a Pipeline when sensors are selected or inputs are rises)
for the columns of the data. Both commands build through here, so
``greyml validate`` scores exactly the model ``greyml fit`` would save.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from greyml._cli import _flags as flags
from greyml._command_names import MODEL_NAMES

__all__ = ["Built", "ModelChoice", "add_model_flags", "build", "model_choice"]

#: The transfer function's settings: the flag's suffix and its parameter.
TRANSFER_SETTINGS = ("state", "reference", "selection", "time_constants", "driver_time_constants")


def add_model_flags(parser, *, model_default=None, reference_flag="--reference"):
    """The flags that choose and configure the model.

    ``model_default``: ``--model`` is required when None. ``reference_flag``:
    the name of the transfer function's ``reference`` flag (``greyml
    validate`` keeps ``--reference`` for the reference it scores in).
    """
    parser.add_argument(
        "--model",
        required=model_default is None,
        default=model_default,
        choices=list(MODEL_NAMES),
        help="the model" + ("" if model_default is None else f" (default: {model_default})"),
    )
    parser.add_argument(
        "--n-sensors",
        type=flags._count,
        metavar="N",
        dest="select",
        help="keep N sensors with GreyInfluenceSelector before the model",
    )
    parser.add_argument(
        "--cluster-on",
        choices=("series", "influence"),
        help="the selector's grouping, with --n-sensors: " + flags._CLUSTER_HELP.split(": ", 1)[1],
    )
    flags._add_names(
        parser,
        "--drivers",
        "--model transfer-function: columns the controller knows (spindle speed, "
        "feed), always inputs and not counted as sensors",
    )
    parser.add_argument(
        "--max-sensors",
        type=flags._count,
        metavar="N",
        help="--model transfer-function: at most N temperature sensors, chosen inside the "
        "fit on held-out whole tests",
    )
    dynamic = parser.add_argument_group("--model transfer-function")
    dynamic.add_argument(
        "--state",
        choices=("auto", "carry", "restart"),
        help="lags at a test's start: auto (default) carries them from the test before on "
        "the same clock, carry from every test before, restart starts each test anew",
    )
    dynamic.add_argument(
        reference_flag,
        choices=("auto", "start", "recording"),
        dest="reference" if reference_flag == "--reference" else "model_reference",
        help="the model's displacement: from each test's start or from the recording's zero; "
        "auto (default): the recording's when the tests are one recording",
    )
    dynamic.add_argument(
        "--selection",
        choices=("forward", "stable"),
        help="how --max-sensors sensors are chosen (default: forward)",
    )
    for flag, metavar, help_text in (
        (
            "--time-constants",
            "S,S|fit",
            "the sensors' lags in seconds (default: 300,900,2700,8100), or fit",
        ),
        (
            "--driver-time-constants",
            "S,S",
            "the drivers' lags in seconds (default: the sensors' and one 3 times slower)",
        ),
    ):
        dynamic.add_argument(flag, type=flags._seconds_list, metavar=metavar, help=help_text)
    flags._add_names(
        parser,
        "--sensors",
        "the model's inputs, or the selector's candidates with --n-sensors, "
        + flags._SENSORS_HELP.split("candidate sensor columns, ", 1)[1],
    )
    parser.add_argument(
        "--rises",
        action="store_true",
        help="inputs as rises from each test's first row (RelativeToStart, saved with the "
        "model); --drivers stay as they are",
    )
    flags._add_random_state(parser, "seed of the model's random choices (default: 0)")


@dataclass(frozen=True)
class ModelChoice:
    """What the flags ask for: the model's name and its settings (None: the default).

    ``reference_flag`` names the transfer function's reference flag in messages.
    """

    model: str
    select: int | None = None
    cluster_on: str | None = None
    sensors: list | None = None
    drivers: list = field(default_factory=list)
    max_sensors: int | None = None
    rises: bool = False
    random_state: int = 0
    transfer: dict = field(default_factory=dict)
    reference_flag: str = "--reference"

    @property
    def dynamic(self):
        return self.model == "transfer-function"


def model_choice(
    model,
    *,
    select=None,
    cluster_on=None,
    sensors=None,
    drivers=None,
    max_sensors=None,
    rises=False,
    random_state=0,
    reference_flag="--reference",
    **transfer,
):
    """A checked :class:`ModelChoice`: one line for flags that do not go together."""
    if model not in MODEL_NAMES:
        raise ValueError(f"unknown model {model!r}; choose one of {', '.join(MODEL_NAMES)}.")
    transfer = {k: transfer.get(k) for k in TRANSFER_SETTINGS}
    dynamic = model == "transfer-function"
    drivers = list(drivers or [])

    def flag(key):
        return reference_flag if key == "reference" else f"--{key.replace('_', '-')}"

    given = [flag(k) for k, v in transfer.items() if v is not None]
    if not dynamic and (drivers or max_sensors is not None or given):
        named = ", ".join(given) or "--drivers and --max-sensors"
        raise ValueError(
            f"{named} {'is' if len(given) == 1 else 'are'} for --model transfer-function; "
            f"{model} takes its inputs from --sensors or --n-sensors."
        )
    if dynamic and select is not None:
        raise ValueError(
            "--model transfer-function chooses its own sensors: give the budget with "
            "--max-sensors instead of --n-sensors."
        )
    return ModelChoice(
        model,
        select,
        cluster_on,
        sensors,
        drivers,
        max_sensors,
        rises,
        random_state,
        transfer,
        reference_flag,
    )


@dataclass(frozen=True)
class Built:
    """An unfitted model for the columns of a file.

    Attributes
    ----------
    estimator : estimator
        The model, or a Pipeline ending in it.
    settings : str
        Its settings in words.
    columns : list of str
        The columns it takes (the drivers first).
    steps : list of str
        The names of the Pipeline's steps before the model (empty: no Pipeline).
    hint : str
        One line on what the user should tell the model, or "".
    """

    estimator: object
    settings: str
    columns: list
    steps: list
    hint: str = ""


def build(choice, frame, columns, data):
    """The unfitted model ``choice`` asks for, on the candidate ``columns`` of ``frame``.

    Checks the drivers (columns of ``data`` with a value in every row) and
    the sensor budgets against the columns there are.
    """
    from sklearn.pipeline import Pipeline

    from greyml._cli._files import _require_columns, _require_values
    from greyml._cli._fitting import _selector
    from greyml._seeds import make_model
    from greyml.preprocessing import RelativeToStart

    drivers = choice.drivers
    if choice.dynamic:
        _require_columns(frame, drivers, data, "--drivers")
        _require_values(frame, drivers, data, "driver")
        columns = drivers + [c for c in columns if c not in drivers]
        n_sensors = len(columns) - len(drivers)
        if choice.max_sensors is not None and choice.max_sensors > n_sensors:
            raise ValueError(
                f"--max-sensors {choice.max_sensors} is more than the {n_sensors} sensor "
                "column(s) besides the drivers."
            )
    estimator, settings = make_model(
        choice.model,
        random_state=choice.random_state,
        drivers=drivers,
        max_sensors=choice.max_sensors,
        **(choice.transfer if choice.dynamic else {}),
    )
    select = choice.select
    n_inputs = select if select is not None else len(columns)
    if select is not None and select > len(columns):
        raise ValueError(
            f"--n-sensors {select} asks for more sensors than the {len(columns)} candidate(s)."
        )
    if choice.model == "anfis-grid" and n_inputs > 6:
        raise ValueError(
            f"anfis-grid on {n_inputs} inputs would need {estimator.n_mfs}^{n_inputs} "
            "rules; keep a few sensors with --n-sensors 5 or --sensors, or use anfis-fcm."
        )
    steps = []
    if choice.rises:
        rising = [c for c in columns if c not in drivers]
        steps.append(("rises", RelativeToStart(columns=rising)))
    if select is not None:
        steps.append(("select", _selector(select, choice.cluster_on, choice.random_state)))
    if steps:
        estimator = Pipeline([*steps, ("model", estimator)])
    hint = _drivers_hint(choice, frame.columns, columns)
    return Built(estimator, settings, columns, [name for name, _ in steps], hint)


#: Column names that read as what a controller knows (speed, feed, power), not a temperature.
_DRIVER_LIKE = re.compile(r"rpm|speed|feed|power|load|torque|current", re.IGNORECASE)


def _drivers_hint(choice, names, candidates):
    """One line when a transfer function has no drivers but a column of the file looks like
    one: left out of the model, or taken as a temperature sensor."""
    if not choice.dynamic or choice.drivers:
        return ""
    like = [c for c in names if _DRIVER_LIKE.search(str(c))]
    if not like:
        return ""
    used = [c for c in like if c in candidates]
    what = (
        f"{', '.join(map(repr, used[:3]))} is taken as a temperature sensor"
        if used
        else f"the model does not use {', '.join(map(repr, like[:3]))}"
    )
    return (
        f"no --drivers given, so {what}; name what the controller knows (spindle speed, "
        f"feed) with --drivers {like[0]}"
    )
