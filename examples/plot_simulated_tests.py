"""
Simulated heating/cooling tests of the VMC and the gantry
==========================================================

``greyml.datasets`` ships tests simulated from the machines of the papers
greyml implements (:doc:`/references`). Here are two of them, each with its
programme, a few of its sensors and the tool-point displacement:

* Test VI of the small vertical milling centre of Abdulshahed et al. (2015):
  8000 rpm for an hour, then an hour of cooling. The paper measured about
  3 µm in X, 79 µm in Y and 22 µm in Z.
* The C-axis test of the 5-axis gantry of Abdulshahed et al. (2016): the C axis in the ram
  runs at 2500 rpm in 10 s bursts for two hours, then everything stands for
  two hours. T1, next to the C-axis motor, rises about 7 °C; the ram grows by
  more than 80 µm in Z. The surface sensors follow the displacement with a
  delay, the FBG strain sensors without.
"""

import matplotlib.pyplot as plt

from greyml.datasets import load_gantry_tests, load_vmc_tests

vmc = load_vmc_tests()
gantry = load_gantry_tests()

test_vi = vmc.frame.xs("VI", level="test")
c_axis = gantry.frame.xs("C-axis", level="test")

for label, frame, data in (("VI", test_vi, vmc), ("C-axis", c_axis, gantry)):
    peaks = ", ".join(f"{t} {frame[t].abs().max():.0f} µm" for t in data.targets)
    print(f"Test {label}: largest displacement {peaks}")

# %%
# One figure, drawn in one piece. Left column, the VMC: the programme, six of
# the 76 temperature sensors (the five that the paper's sensor selection
# keeps, and T11) and X, Y, Z. Right column, the gantry: C-axis speed (mean
# over each 20 s sample: the axis runs half of the time), the ram's
# temperature sensors, two FBGs and the Z growth of the ram.

fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex="col", layout="constrained")
minutes = test_vi.index / 60
axes[0, 0].step(minutes, test_vi["spindle_rpm"], where="post")
axes[0, 0].set_ylabel("spindle (rpm)")
axes[0, 0].set_title("VMC, Test VI (Abdulshahed et al. 2015)")
for name in ("T11_C", "T18_C", "T55_C", "T63_C", "T68_C", "T71_C"):
    axes[1, 0].plot(minutes, test_vi[name], label=f"{name[:-2]} ({vmc.sensor_groups[name]})")
axes[1, 0].set_ylabel("temperature (°C)")
_ = axes[1, 0].legend(fontsize=7)
for name in vmc.targets:
    axes[2, 0].plot(minutes, test_vi[name], label=name)
axes[2, 0].set_ylabel("displacement (µm)")
axes[2, 0].set_xlabel("time (min)")
_ = axes[2, 0].legend(fontsize=8)

minutes = c_axis.index / 60
axes[0, 1].step(minutes, c_axis["c_rpm"], where="post")
axes[0, 1].set_ylabel("C axis (rpm, mean)")
axes[0, 1].set_title("Gantry, C-axis test (Abdulshahed et al. 2016)")
for name in ("T1_C", "T2_C", "T3_C", "T4_C", "T7_C"):
    axes[1, 1].plot(minutes, c_axis[name], label=f"{name[:-2]} ({gantry.sensor_groups[name]})")
axes[1, 1].set_ylabel("temperature (°C)")
_ = axes[1, 1].legend(fontsize=7)
ax = axes[2, 1]
ax.plot(minutes, c_axis["dz_um"], color="k", label="dz_um")
ax.set_ylabel("displacement (µm)")
ax.set_xlabel("time (min)")
strain = ax.twinx()
for name in ("FBG1_ue", "FBG2_ue"):
    strain.plot(minutes, c_axis[name], lw=0.8, label=name)
strain.set_ylabel("strain (µε)")
ax.legend(loc="upper left", fontsize=8)
_ = strain.legend(loc="upper right", fontsize=8)

plt.show()
# sphinx_gallery_multi_image = "single"
