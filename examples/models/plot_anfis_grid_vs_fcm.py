"""
ANFIS with a grid partition or with fuzzy c-means rules
=======================================================

Both ANFIS models in greyml are first-order Takagi–Sugeno systems: each rule
says "IF the sensors are about here THEN the displacement is this linear
function of them", and the prediction blends the rules by how strongly each
one fires. They differ in how the rules are laid out before training:

* ``ANFISGrid(n_mfs=m)`` splits the range of every input into ``m`` fuzzy
  sets and makes one rule for every combination: mⁿ rules on n inputs.
* ``ANFISFCM(n_clusters=c)`` runs fuzzy c-means on the training data and
  makes one rule per cluster, whatever the number of inputs.

The data is greyml's simulation of the small VMC of Abdulshahed et al. (2015)
(``greyml.datasets.load_vmc_tests``). We take the five sensors that
``GreyInfluenceSelector(5, cluster_on="series")`` keeps on Test IV (T65 on
the motors, T25 and T53 on the two spindle carrier strips, T71 in the air
near the base, T8 on the column) as temperature rises from each test's
start. Both models are trained on Test IV (4000 rpm), as in that paper, and
predict ``dy_um`` on the other five tests from the temperatures alone:
Tests I-III also run at 4000 rpm, Tests V and VI at 8000 rpm.

Why two fuzzy sets per input, not three: the paper's best grid had 3 MFs on
5 inputs, 243 rules with 243 × 6 = 1,458 consequent parameters, fitted on
Test IV's 481 rows. On this 2-core machine that fit took 43 s, and it did
worse on the other tests (25.5 µm RMSE together) than the 2-MF grid printed
below. Two MFs give 32 rules, which fit in a fraction of a second.

Even 32 rules are too many here. The five temperatures rise together, so
the training data fill only a thin band of the five-dimensional grid, and
most grid rules are never the strongest rule on any training row. At
8000 rpm the temperatures leave that band, and the prediction passes to
those rules, whose linear consequents were hardly constrained. The
fuzzy c-means rules sit where the training data are: every rule that leads
at 8000 rpm has led on training rows too.

When to pick which:

* **ANFISGrid** for two or three inputs that vary independently, when you
  want a partition you can read ("T65 low / T65 high") and the rule count
  mⁿ stays small beside the number of training rows.
* **ANFISFCM** for more inputs, or inputs that move together (most
  temperature sensors on one machine): c rules where the data are, a rule
  count that does not grow with the inputs, and a fit that stays fast.
"""

# %%

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from greyml import ANFISFCM, ANFISGrid, RelativeToStart, groups_of
from greyml.datasets import load_vmc_tests
from greyml.fuzzy._kernels import log_firing, normalised_firing
from greyml.metrics import rmse

SENSORS = ["T65_C", "T25_C", "T53_C", "T71_C", "T8_C"]
TRAIN = "IV"

vmc = load_vmc_tests()
X = vmc.frame[SENSORS]
X = RelativeToStart().fit_transform(X)  # rises, °C
y = vmc.frame["dy_um"]
tests = np.asarray(groups_of(X))
train = tests == TRAIN
rpm = vmc.frame["spindle_rpm"].groupby(level="test", sort=False).max()
print(
    f"Simulated VMC: trained on Test {TRAIN} ({train.sum()} rows, {rpm[TRAIN]:.0f} rpm); "
    f"inputs: {', '.join(f'{s} ({vmc.sensor_groups[s]})' for s in SENSORS)}"
)

# %%
# Train both models on Test IV
# ----------------------------
models = {
    "ANFISGrid(2 MFs)": ANFISGrid(n_mfs=2, random_state=0),
    "ANFISFCM(3)": ANFISFCM(n_clusters=3, random_state=0),
}
predictions = {}
for name, model in models.items():
    model.fit(X[train], y[train])
    predictions[name] = model.predict(X)
    print(f"{name}: {model.n_rules_} rules, best epoch {model.best_epoch_}/{model.n_iter_}")

# %%
# RMSE on every test
# ------------------
# Test IV is the training test; the others are validation.
rows = {}
for t in vmc.tests:
    rows[t] = {"rpm": int(rpm[t])}
    for name, pred in predictions.items():
        rows[t][name] = rmse(y[tests == t], pred[tests == t])
table = pd.DataFrame(rows).T
table.loc["all but IV"] = [np.nan] + [rmse(y[~train], p[~train]) for p in predictions.values()]
print("\nRMSE of dy_um (µm)")
print(
    table.to_string(
        formatters={"rpm": "{:.0f}".format},
        float_format="{:.2f}".format,
        na_rep="",
    )
)


# %%
# Which rules lead, on the training data and at 8000 rpm
# ------------------------------------------------------
# For each row, the rule with the largest normalised firing strength leads.
# ``rules_`` holds every rule's centres and widths in °C, so the firing
# strengths can be recomputed from the readable rules.
def leading_rules(model, rows):
    centres = np.array([[c for _, c, _ in rule["if"]] for rule in model.rules_])
    widths = np.array([[s for _, _, s in rule["if"]] for rule in model.rules_])
    w = normalised_firing(log_firing(X[rows].to_numpy(), centres, widths))
    return np.bincount(w.argmax(axis=1), minlength=model.n_rules_)


print("\nRules that lead on at least one row")
for name, model in models.items():
    lead_train = leading_rules(model, train)
    counts = [f"Test {TRAIN}: {np.count_nonzero(lead_train)} of {model.n_rules_}"]
    for t in ("V", "VI"):
        lead = leading_rules(model, tests == t)
        never = np.count_nonzero((lead > 0) & (lead_train == 0))
        share = lead[lead_train == 0].sum() / lead.sum()
        counts.append(
            f"Test {t}: {np.count_nonzero(lead)}, {never} of them never on Test {TRAIN} "
            f"(they lead {100 * share:.0f} % of Test {t}'s rows)"
        )
    print(f"  {name}: " + "; ".join(counts))
t65 = X["T65_C"].groupby(level="test", sort=False).max()
print(
    f"  T65 rises {t65[TRAIN]:.1f} °C in Test {TRAIN}, {t65['V']:.1f} °C in V and "
    f"{t65['VI']:.1f} °C in VI"
)

# %%
# The rules as text
# -----------------
# The grid's rules share their fuzzy sets: each input has a "low" and a
# "high" set, and the 32 rules are the combinations. Its partition is
# easiest to read input by input. The c-means rules each have their own
# sets, one per input, centred on a cluster of the training data.
grid, fcm = models["ANFISGrid(2 MFs)"], models["ANFISFCM(3)"]
print("\nANFISGrid: the fuzzy sets of each input (centre, σ in °C)")
for j, sensor in enumerate(SENSORS):
    sets = sorted({(rule["if"][j][1], rule["if"][j][2]) for rule in grid.rules_})
    print(f"  {sensor}: " + ", ".join(f"about {c:.2f} (σ {s:.2f})" for c, s in sets))
print("\nANFISGrid: the first 3 of 32 rules")
print(grid.describe_rules(unit="°C", max_rules=3))
print("\nANFISFCM: all 3 rules")
print(fcm.describe_rules(unit="°C"))

# %%
# Measured against predicted, and the fuzzy sets of T65
# -----------------------------------------------------
# Top: one validation test at each speed. Bottom: the membership functions
# of T65 (motors) in the two models, with the range T65 covers in the
# training test and in Test VI.
fig, axes = plt.subplots(2, 2, figsize=(11, 7), layout="constrained")
for ax, t in zip(axes[0], ("II", "VI")):
    rows_t = tests == t
    minutes = X[rows_t].index.get_level_values("time_s") / 60
    ax.plot(minutes, y[rows_t], color="black", lw=2, label="measured (simulated)")
    for name, pred in predictions.items():
        ax.plot(minutes, pred[rows_t], label=f"{name}: {table.loc[t, name]:.1f} µm")
    ax.set_title(f"Test {t}, {rpm[t]:.0f} rpm (trained on Test {TRAIN})", fontsize=10)
    ax.set_xlabel("time (min)")
    ax.set_ylabel("dy (µm)")
    ax.legend(fontsize=8)

grid_t = np.linspace(-2.0, 23.0, 400)
for ax, (name, model) in zip(axes[1], models.items()):
    sets = sorted({(rule["if"][0][1], rule["if"][0][2]) for rule in model.rules_})
    for k, (c, s) in enumerate(sets):
        ax.plot(grid_t, np.exp(-0.5 * ((grid_t - c) / s) ** 2), label=f"set {k + 1}: {c:.1f} °C")
    lo, hi = X.loc[train, "T65_C"].min(), X.loc[train, "T65_C"].max()
    ax.axvspan(lo, hi, color="0.85", label=f"Test {TRAIN}")
    ax.axvline(t65["VI"], color="C3", ls="--", label="Test VI's largest rise")
    ax.set_title(f"{name}: fuzzy sets of T65 (motors)", fontsize=10)
    ax.set_xlabel("T65 rise (°C)")
    ax.set_ylabel("membership")
    ax.legend(fontsize=8, loc="upper right")

# sphinx_gallery_start_ignore
# as a script with $GREYML_EXAMPLE_OUT naming a folder, the figures are saved there too
import os  # noqa: E402

out = os.environ.get("GREYML_EXAMPLE_OUT")
if out:
    path = os.path.join(out, "anfis_grid_vs_fcm.png")
    fig.savefig(path, dpi=100)
    print(f"\nplot written to {path}")
# sphinx_gallery_end_ignore
plt.show()
# sphinx_gallery_multi_image = "single"
