"""The landing page's figure: measured and predicted drift on held-out tests.

GMC(1,N) on five temperature rises, calibrated by least squares on Test IV
of greyml's simulated VMC and predicting three tests it has not seen. Run by
matplotlib's plot directive when the documentation is built (about 2 s).
"""

import matplotlib.pyplot as plt

from greyml import GMC, RelativeToStart
from greyml.datasets import load_vmc_tests
from greyml.metrics import rmse

vmc = load_vmc_tests()
sensors = ["T18_C", "T55_C", "T63_C", "T68_C", "T71_C"]
X = vmc.frame[sensors]
X = RelativeToStart().fit_transform(X)  # rises from each test's start
y = vmc.frame["dy_um"]
tests = X.index.get_level_values("test")
model = GMC(solver="ls").fit(X[tests == "IV"], y[tests == "IV"])

held_out = ["II", "V", "VI"]
fig, axes = plt.subplots(1, 3, figsize=(12, 2.6), sharey=True, layout="constrained")
for ax, test in zip(axes, held_out):
    rows = tests == test
    minutes = X[rows].index.get_level_values("time_s") / 60
    predicted = model.predict(X[rows])
    ax.plot(minutes, y[rows], color="k", lw=1.6, label="measured")
    ax.plot(minutes, predicted, color="C1", lw=1.6, ls="--", label="GMC prediction")
    ax.set_title(
        f"Test {test}, not seen in training: RMSE {rmse(y[rows], predicted):.1f} µm", fontsize=10
    )
    ax.set_xlabel("time (min)")
axes[0].set_ylabel("Y drift of the tool (µm)")
axes[0].legend(fontsize=8, loc="lower right")
fig.suptitle(
    "GMC(1,N) on five temperature rises, calibrated on Test IV of a simulated VMC", fontsize=10
)
