"""
Lag features and a streaming compensator on the simulated VMC
=============================================================

Heat takes minutes to hours to travel through a machine's structure, so the
drift of the tool does not follow the temperatures at the same instant.
``greyml.LagFeatures`` adds first-order lags of every input (time constants
of 5, 15, 45 and 135 min here), after which a ridge regression can follow the
drift. Both models below, ridge on five temperature rises and ridge on the
same rises with their lags, are trained on Tests I, IV and V of the simulated
VMC (4000 and 8000 rpm) and predict Tests II, III and VI, which they have not
seen.

``greyml.Compensator`` then runs the fitted lag model row by row, as a
machine's controller would, and gives the same prediction as the batch
pipeline.
"""

# %%
import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import Compensator, LagFeatures, RelativeToStart
from greyml.datasets import load_vmc_tests
from greyml.metrics import rmse

vmc = load_vmc_tests()
sensors = ["T8_C", "T25_C", "T53_C", "T65_C", "T71_C"]
X = vmc.frame[sensors]
X = RelativeToStart().fit_transform(X)  # rises from each test's start
y = vmc.frame["dy_um"]
tests = X.index.get_level_values("test")
train = np.isin(tests, ["I", "IV", "V"])

alphas = np.logspace(-3, 3, 13)
static = make_pipeline(StandardScaler(), RidgeCV(alphas=alphas)).fit(X[train], y[train])
lags = LagFeatures([300, 900, 2700, 8100])  # seconds
dynamic = make_pipeline(lags, StandardScaler(), RidgeCV(alphas=alphas)).fit(X[train], y[train])

print("held-out RMSE of dy_um (µm): ridge on the rises, ridge on the rises and their lags")
for test in ("II", "III", "VI"):
    rows = tests == test
    print(
        f"  Test {test:<3}  {rmse(y[rows], static.predict(X[rows])):5.2f}"
        f"  {rmse(y[rows], dynamic.predict(X[rows])):5.2f}"
    )

# %%
# The controller's loop on Test VI: one row at a time, with its time.
comp = Compensator.from_pipeline(dynamic)
rows = X[tests == "VI"]
times = rows.index.get_level_values("time_s")
streamed = np.array(
    [comp.update({"time_s": t, **row}) for t, (_, row) in zip(times, rows.iterrows())]
)
batch = dynamic.predict(rows)
print(f"largest difference, streamed against batch: {np.abs(streamed - batch).max():.1e} µm")

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), layout="constrained")
for ax, test in zip(axes, ("III", "VI")):
    rows = tests == test
    minutes = X[rows].index.get_level_values("time_s").to_numpy() / 60
    ax.plot(minutes, y[rows], color="k", lw=2, label="measured (simulated)")
    ax.plot(minutes, static.predict(X[rows]), color="C0", label="ridge on the rises")
    ax.plot(minutes, dynamic.predict(X[rows]), color="C1", label="ridge on the rises and lags")
    ax.set_xlabel("time (min)")
    ax.set_title(f"Test {test}, held out", fontsize=10)
axes[1].plot(minutes, streamed, color="C3", ls=":", lw=2, label="the same, streamed")
axes[0].set_ylabel("Y drift of the tool (µm)")
axes[1].legend(fontsize=8)
plt.show()
# sphinx_gallery_multi_image = "single"
