"""
Are the probabilities right? A reliability diagram
==================================================

A zero-shot model ranks the unseen classes with probabilities (``predict_proba``). On a robot
these probabilities decide when to stop touching, so they should mean what they say: among the
trials where the top class gets probability 0.8, about 80% should be right. A reliability diagram
plots, in bins of the top probability (the *confidence*), the share of trials that were right
against the mean confidence; the expected calibration error (ECE) is the trial-weighted mean gap.

Computed here with numpy and :func:`sklearn.calibration.calibration_curve` on **simulated**
data; every number below comes from the simulation.
"""

# %%
# Fit two methods on the training objects of one split
# ----------------------------------------------------
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from sklearn.calibration import calibration_curve

from tzsl.datasets import synthetic_dataset_arrays
from tzsl.evaluation import random_object_splits
from tzsl.models import build_method

K, cls, X = synthetic_dataset_arrays(600, n_classes=40, n_attributes=14, n_sensors=2, n_features=8, seed=2)
objects = np.array([f"c{c:02d}" for c in range(len(K))])
table = pd.DataFrame(K, index=objects, columns=[f"a{j:02d}" for j in range(K.shape[1])])
split = random_object_splits(table, n_test=10, n_splits=1, random_state=0, min_train_positives=2)[0]
cols = [table.columns.get_loc(a) for a in split.kept_attributes]
train = np.isin(objects[cls], split.train_objects)
test = np.isin(objects[cls], split.test_objects)
unseen = np.flatnonzero(np.isin(objects, split.test_objects))
truth = np.searchsorted(unseen, cls[test])
X_flat = X.reshape(len(X), -1)

probabilities = {}
for name in ["eszsl", "iap"]:
    model = build_method(name, random_state=0).fit(X_flat[train], K[cls[train]][:, cols], groups=cls[train])
    probabilities[name] = model.predict_proba(X_flat[test], class_attributes=K[unseen][:, cols])
    print(name, "class posteriors:", probabilities[name].shape, "(test trials x unseen classes)")

# %%
# Confidence against accuracy
# ---------------------------
# The confidence of a trial is its top class probability; it is right when that class is the
# trial's class. ``calibration_curve`` bins the confidences and returns, per non-empty bin, the
# share right and the mean confidence.
n_bins = 5
edges = np.linspace(0, 1, n_bins + 1)
fig, ax = plt.subplots(figsize=(4.5, 4.5))
ax.plot([0, 1], [0, 1], color="grey", linestyle="--", label="perfectly calibrated")
for name, proba in probabilities.items():
    confidence = proba.max(axis=1)
    right = (proba.argmax(axis=1) == truth).astype(int)
    share_right, mean_confidence = calibration_curve(right, confidence, n_bins=n_bins, strategy="uniform")
    counts = np.histogram(confidence, bins=edges)[0]
    counts = counts[counts > 0]  # calibration_curve leaves empty bins out
    ece = float(np.sum(counts * np.abs(share_right - mean_confidence)) / counts.sum())
    print(f"{name}: accuracy {right.mean():.3f}, mean confidence {confidence.mean():.3f}, ECE {ece:.3f}")
    ax.plot(mean_confidence, share_right, marker="o", label=f"{name} (ECE {ece:.2f})")
ax.set_xlabel("confidence (top class probability)")
ax.set_ylabel("share of trials right")
ax.set_xlim(0, 1)
ax.set_ylim(0, 1)
ax.set_title("Reliability on SIMULATED data")
ax.legend(loc="upper left", fontsize="small")
fig.tight_layout()
plt.show()

# %%
# A curve below the diagonal is over-confident, above it under-confident. Probabilities are
# checked like accuracies: on test objects only, and a calibrator, if any, is fitted on training
# objects only.
