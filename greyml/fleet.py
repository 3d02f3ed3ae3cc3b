"""Many machines' models at once, and one model from many machines' rows, on Dask.

A plant logs every machine around the clock; each machine has its own model.
:func:`fit_fleet` fits one clone of an estimator per machine, each on that
machine's pieces of data (what :meth:`~greyml.ThermalTransferFunction.fit_chunks`
takes, e.g. a :class:`greyml.io.TestFiles` naming its files): on a Dask
cluster each worker reads its own machine's files and sends back only the
fitted model; without a cluster, one machine after another in this process.
Either way the models are the same, to rounding (a worker's BLAS may sum in
another order).

:class:`Partitions` turns a ``dask.dataframe`` (flat columns: the test labels,
``time_s``, the target, the inputs) into those pieces, one partition at a
time, each computed on the cluster where its files are read: one model from
rows no machine holds at once. The lags run through the partitions in order,
so their statistics are summed in the client as each partition arrives (the
next is being computed meanwhile); the model equals ``fit`` on the rows
stacked.

Dask (``dask``, ``distributed``) is the ``distributed`` extra; greyml imports
neither until a cluster is used.
"""

from __future__ import annotations

from collections.abc import Mapping

from sklearn.base import clone

from greyml.io._pieces import piece_of

__all__ = ["Partitions", "fit_fleet"]


def _fit_one(estimator, pieces):
    return estimator.fit_chunks(pieces)


def fit_fleet(estimator, machines, *, client=None):
    """One model per machine, each fitted on its own pieces of data.

    Parameters
    ----------
    estimator : ThermalTransferFunction
        The unfitted model; each machine gets a clone.
    machines : mapping of str to pieces
        Each machine's pieces, as ``fit_chunks`` takes them (a
        :class:`greyml.io.TestFiles`: only the file names travel to a worker,
        which reads the files itself).
    client : distributed.Client, optional
        The cluster's client (``Client("tcp://scheduler:8786")`` for a real
        one, ``Client(LocalCluster())`` on this machine). Without it the
        machines are fitted one after another here.

    Returns
    -------
    models : dict of str to fitted estimator
        In the order of ``machines``. A machine whose data are refused raises
        its error here, naming it.

    Examples
    --------
    >>> from distributed import Client, LocalCluster  # doctest: +SKIP
    >>> from greyml import ThermalTransferFunction
    >>> from greyml.fleet import fit_fleet
    >>> from greyml.io import TestFiles
    >>> names = ("vmc-1", "vmc-2")
    >>> machines = {m: TestFiles(f"logs/{m}/", "dx_um") for m in names}  # doctest: +SKIP
    >>> with Client(LocalCluster(n_workers=2)) as client:  # doctest: +SKIP
    ...     models = fit_fleet(ThermalTransferFunction(drivers=["spindle_rpm"]), machines,
    ...                        client=client)
    """
    if not isinstance(machines, Mapping) or not machines:
        raise ValueError("fit_fleet: machines must be a non-empty mapping of name to pieces.")
    names = [str(name) for name in machines]
    if len(set(names)) != len(names):
        raise ValueError("fit_fleet: two machines have the same name.")
    models = {}
    if client is None:
        for name, pieces in zip(names, machines.values()):
            models[name] = _named(name, _fit_one, clone(estimator), pieces)
        return models
    futures = [
        client.submit(
            _named, name, _fit_one, clone(estimator), pieces, key=f"greyml-fit-{k}-{name}"
        )
        for k, (name, pieces) in enumerate(zip(names, machines.values()))
    ]
    for name, future in zip(names, futures):
        models[name] = future.result()
    return models


def _named(name, function, *args):
    """``function(*args)``, an error in it naming the machine."""
    try:
        return function(*args)
    except ValueError as error:
        raise ValueError(f"machine {name!r}: {error}") from None


class Partitions:
    """The partitions of a ``dask.dataframe``, as pieces of data for ``fit_chunks``.

    Parameters
    ----------
    frame : dask.dataframe.DataFrame
        Flat columns: ``test_column``, ``time_s``, ``target`` and the inputs,
        its partitions in the order of the rows (a test may run on from one
        partition into the next).
    target : str
        The displacement column.
    test_column : str, default="test"
    time_unit : {"s", "min", "h"}, default="s"

    Each iteration computes the partitions in order on the frame's cluster,
    the next while the current one is used, and gives ``(X, y)`` in greyml's
    layout; one partition is held here at a time.

    Examples
    --------
    >>> import dask.dataframe as dd  # doctest: +SKIP
    >>> from greyml import ThermalTransferFunction
    >>> from greyml.fleet import Partitions
    >>> frame = dd.read_parquet("logs/plant/*.parquet")  # doctest: +SKIP
    >>> model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(
    ...     Partitions(frame, "dx_um"))  # doctest: +SKIP
    """

    def __init__(self, frame, target, *, test_column="test", time_unit="s"):
        self.frame = frame
        self.target = str(target)
        self.test_column = str(test_column)
        self.time_unit = time_unit

    def __repr__(self):
        return f"Partitions({self.frame.npartitions} partitions, target={self.target!r})"

    def __iter__(self):
        from distributed import default_client

        client = default_client()
        n = self.frame.npartitions
        ahead = client.compute(self.frame.partitions[0]) if n else None
        for i in range(n):
            current = ahead
            ahead = client.compute(self.frame.partitions[i + 1]) if i + 1 < n else None
            yield piece_of(
                current.result(),
                target=self.target,
                test_column=self.test_column,
                time_unit=self.time_unit,
                where=f"partition {i}",
            )
