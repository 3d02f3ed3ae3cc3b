"""The main job's numbers, asserted, so a regression in GMC or the data shows."""

import numpy as np

from greyml import GMC
from greyml.datasets import load_probe_test
from greyml.metrics import rmse


def test_probe_test_pso_gmc_against_linear_reference():
    data = load_probe_test()
    X = data.frame[data.sensors] - data.frame[data.sensors].iloc[0]
    y = (data.frame["dz_um"] - data.frame["dz_um"].iloc[0]).to_numpy()
    k = len(y) // 2
    model = GMC(solver="pso", bounds=(0.0, 100.0), random_state=0).fit(X.iloc[:k], y[:k])
    err = rmse(y[k:], model.predict(X)[k:])
    # measured when written: 9.74 µm (a plain linear regression gets 0.76 µm); see the
    # issue notes: GMC's first-order lag cannot lead its drivers, and the simulated
    # surface sensors lag the displacement
    assert err < 15.0
    assert np.isfinite(model.predict(X)).all()
