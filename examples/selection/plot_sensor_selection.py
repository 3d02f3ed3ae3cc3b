"""
Choosing five of 76 temperature sensors
=======================================

Abdulshahed et al. (2015) fitted 76 temperature sensors to a small vertical milling centre
(VMC) and then asked which few of them a compensation model needs.
``greyml.GreyInfluenceSelector`` answers it in three steps:

1. **Influence.** A GM(1,N) grey model of the displacement against all the
   sensors, each scaled to [0, 1], gives every sensor a weight
   (``influence_``). A large weight, positive or negative, means a large
   influence.
2. **Groups.** Fuzzy c-means sorts the sensors into ``n_clusters`` groups.
   With ``cluster_on="influence"`` (the paper's way) it groups the weights
   themselves, so sensors with similar weights go together. With
   ``cluster_on="series"`` it groups the scaled series, so sensors that
   move together go together.
3. **Pick.** The sensor with the largest weight in each group is kept.

The data is greyml's simulation of the paper's six tests
(``greyml.datasets.load_vmc_tests``), as temperature rises from each test's
start; the target is the Y displacement ``dy_um``; the selector is fitted on
Test IV, as in the paper. ``sensor_groups`` names the machine part of every
sensor: the base, the column, the two spindle carrier strips, the spindle
boss, the motors, the ballscrews and the air near the column and the base.

What comes out:

* Grouping the series gives groups that mostly follow the machine's
  parts: column, base and ballscrews; the air; strip 1; strip 2; the
  spindle boss with 13 sensors of the two strips. The five sensors kept come
  from five parts. An ANFIS model on them predicts the other tests more
  than twice as well as one on the sensors kept by grouping the weights.
* Grouping the weights mixes the parts: 76 sensors that warm up nearly
  together share the influence between them, neighbours often with
  opposite signs, so similar weights do not mean similar sensors. Three of
  its five picks lie on the same carrier strip.
* The weights depend on the training test: fitted on another test, other
  sensors lead. Grouping the series still spreads the picks over the parts.
"""

# %%

from collections import Counter

import matplotlib.pyplot as plt
import numpy as np

from greyml import ANFISFCM, GreyInfluenceSelector, RelativeToStart, groups_of
from greyml.datasets import load_vmc_tests
from greyml.metrics import rmse

TRAIN = "IV"
N_GROUPS = 5

vmc = load_vmc_tests()
X = vmc.frame[vmc.sensors]
X = RelativeToStart().fit_transform(X)  # rises, °C
y = vmc.frame["dy_um"]
tests = np.asarray(groups_of(X))
train = tests == TRAIN
names = np.asarray(vmc.sensors)
part = vmc.sensor_groups
print(
    f"Simulated VMC: {len(names)} sensors on {len(set(part.values()))} parts, "
    f"fitted on Test {TRAIN} ({train.sum()} rows)"
)

selectors = {
    on: GreyInfluenceSelector(N_GROUPS, cluster_on=on, random_state=0).fit(X[train], y[train])
    for on in ("series", "influence")
}

# %%
# The influence ranking
# ---------------------
# The GM(1,N) fit and so the weights are the same for both settings of
# ``cluster_on``; only the grouping differs.
influence = selectors["series"].influence_
order = np.argsort(-np.abs(influence))
print("\nThe 10 most influential sensors (GM(1,N) weight, sensors scaled to [0, 1])")
for rank, j in enumerate(order[:10], start=1):
    print(f"  {rank:2d}. {names[j]:6s} {influence[j]:+.3f}  {part[names[j]]}")
corr = np.corrcoef(X.loc[train, ["T25_C", "T26_C"]].to_numpy().T)[0, 1]
w25, w26 = influence[names == "T25_C"][0], influence[names == "T26_C"][0]
print(
    f"T25 and T26, neighbours on carrier strip 1, correlate at {corr:.4f} on Test {TRAIN}, "
    f"yet weigh {w25:+.3f} and {w26:+.3f}:\nwith this many near-copies, the weights are "
    "shared out between neighbours, not measured one by one."
)


# %%
# The groups
# ----------
# For each group: its size, the machine parts its sensors sit on, and the
# sensor kept, with its membership of the group (1 = wholly in it).
def describe_groups(selector):
    kept = dict(zip(names[selector.support_], np.flatnonzero(selector.support_)))
    for k in range(selector.n_clusters):
        members = names[selector.clusters_ == k]
        parts = Counter(part[m] for m in members).most_common()
        pick = [name for name in members if name in kept]
        pick_txt = (
            f"keeps {pick[0]} ({part[pick[0]]}, membership "
            f"{selector.membership_[k, kept[pick[0]]]:.2f})"
            if pick
            else "keeps nothing"
        )
        print(f"  group {k + 1}: {len(members):2d} sensors, {pick_txt}")
        print("           " + ", ".join(f"{p} {n}" for p, n in parts))
    between = np.count_nonzero(selector.membership_.max(axis=0) < 0.5)
    print(f"  {between} sensors belong to no group by more than 0.5")


for on, selector in selectors.items():
    print(f'\ncluster_on="{on}": {N_GROUPS} groups')
    describe_groups(selector)

# %%
# The two selections compared
# ---------------------------
# The kept sensors, the parts they cover, the same pick for five random
# states, and the RMSE of ``ANFISFCM(3)`` trained on Test IV with them and
# predicting the other tests.
print("\nKept sensors and what they are worth")
scores = {}
for on, selector in selectors.items():
    kept = selector.selected_
    same = all(
        GreyInfluenceSelector(N_GROUPS, cluster_on=on, random_state=seed)
        .fit(X[train], y[train])
        .selected_
        == kept
        for seed in range(1, 5)
    )
    model = ANFISFCM(n_clusters=3, random_state=0).fit(X.loc[train, kept], y[train])
    pred = model.predict(X[kept])
    scores[on] = rmse(y[~train], pred[~train])
    per_test = "  ".join(
        f"{t} {rmse(y[tests == t], pred[tests == t]):.2f}" for t in vmc.tests if t != TRAIN
    )
    print(f'  cluster_on="{on}": {", ".join(kept)}')
    print(
        f"      {len({part[s] for s in kept})} parts: {', '.join(part[s] for s in kept)}; "
        f"same pick for random_state 0-4: {'yes' if same else 'no'}"
    )
    print(f"      ANFISFCM(3) RMSE on the other tests {scores[on]:.2f} µm ({per_test})")

# %%
# How much the pick depends on the training test
# ----------------------------------------------
# The paper chose its sensors on Test IV. Fitted on each of the other tests
# in turn (``cluster_on="series"``), the selector keeps:
print('\nKept sensors (cluster_on="series") by training test')
for t in vmc.tests:
    rows = tests == t
    kept = (
        GreyInfluenceSelector(N_GROUPS, cluster_on="series", random_state=0)
        .fit(X[rows], y[rows])
        .selected_
    )
    print(
        f"  Test {t:3s} ({rows.sum():3d} rows): {' '.join(s.removesuffix('_C') for s in kept):22s}"
        f" on {len({part[s] for s in kept})} parts"
    )

# %%
# The weights and the groups, sensor by sensor
# --------------------------------------------
# Sensors are numbered part by part. Each bar is a sensor's weight,
# coloured by its group; stars mark the kept sensors.
fig, axes = plt.subplots(2, 1, figsize=(12, 7), sharex=True, layout="constrained")
number = np.arange(1, len(names) + 1)
edges = [0] + [i + 1 for i in range(len(names) - 1) if part[names[i]] != part[names[i + 1]]]
edges.append(len(names))
for ax, (on, selector) in zip(axes, selectors.items()):
    colours = plt.cm.tab10(selector.clusters_)
    ax.bar(number, influence, color=colours, width=0.8)
    kept = selector.support_
    tip = influence[kept] + np.sign(influence[kept]) * 0.008
    ax.scatter(number[kept], tip, marker="*", s=150, color="black", zorder=3)
    for j in np.flatnonzero(kept):
        ax.annotate(
            names[j].removesuffix("_C"),
            (number[j], tip[list(np.flatnonzero(kept)).index(j)]),
            xytext=(4, 0),
            textcoords="offset points",
            fontsize=8,
            va="center",
        )
    for edge in edges[1:-1]:
        ax.axvline(edge + 0.5, color="0.7", lw=0.7)
    ax.axhline(0, color="black", lw=0.5)
    ax.set_ylabel("influence weight")
    handles = [
        plt.Rectangle((0, 0), 1, 1, color=plt.cm.tab10(k)) for k in range(selector.n_clusters)
    ]
    ax.legend(
        handles,
        [f"group {k + 1}" for k in range(selector.n_clusters)],
        fontsize=7,
        ncol=5,
        loc="lower left",
    )
    ax.set_title(
        f'cluster_on="{on}": kept {", ".join(selector.selected_)} '
        f"(ANFISFCM on the other tests: {scores[on]:.2f} µm)",
        fontsize=10,
    )
SHORT = {
    "spindle carrier strip 1": "strip 1",
    "spindle carrier strip 2": "strip 2",
    "spindle boss": "boss",
    "ambient near the column": "air (column)",
    "ambient near the base": "air (base)",
}
parts_axis = axes[0].secondary_xaxis("top")
parts_axis.set_xticks(
    [(lo + hi) / 2 + 0.5 for lo, hi in zip(edges[:-1], edges[1:])],
    [SHORT.get(part[names[lo]], part[names[lo]]) for lo in edges[:-1]],
    rotation=30,
    ha="left",
    fontsize=7,
)
axes[1].set_xlabel("sensor number (T1-T76)")

# %%
# Sensors that move together
# --------------------------
# The groups found by ``cluster_on="series"``: every member's rise on
# Test IV, scaled to [0, 1], with the kept sensor in black.
selector = selectors["series"]
Xn = X[train]
Xn = (Xn - Xn.min()) / (Xn.max() - Xn.min())
minutes = Xn.index.get_level_values("time_s") / 60
fig2, axes2 = plt.subplots(1, N_GROUPS, figsize=(13, 3), sharey=True, layout="constrained")
for k, ax in enumerate(axes2):
    members = names[selector.clusters_ == k]
    for m in members:
        ax.plot(minutes, Xn[m], color=plt.cm.tab10(k), lw=0.6, alpha=0.6)
    pick = [m for m in members if m in selector.selected_]
    for m in pick:
        ax.plot(minutes, Xn[m], color="black", lw=1.5, label=m)
    ax.set_title(f"group {k + 1}: {len(members)} sensors", fontsize=9)
    ax.set_xlabel("time (min)")
    if pick:
        ax.legend(fontsize=7, loc="lower right")
axes2[0].set_ylabel(f"rise on Test {TRAIN}, scaled")

# sphinx_gallery_start_ignore
# as a script with $GREYML_EXAMPLE_OUT naming a folder, the figures are saved there too
import os  # noqa: E402

out = os.environ.get("GREYML_EXAMPLE_OUT")
for name, figure in (("sensor_selection.png", fig), ("sensor_groups.png", fig2)):
    if out:
        path = os.path.join(out, name)
        figure.savefig(path, dpi=100)
        print(f"plot written to {path}")
# sphinx_gallery_end_ignore
plt.show()
# sphinx_gallery_multi_image = "single"
