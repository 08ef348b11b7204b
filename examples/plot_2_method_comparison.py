"""
Comparing zero-shot methods on the same splits
==============================================

Several methods of the registry (``tzsl methods``) are fitted on the same random object splits
of a **simulated** dataset and compared as tzsl's studies compare them: the accuracy of each with
its 95% interval, and each method minus a reference method *on the same test trials*, with the
interval of that paired difference. Every number below comes from simulated data.
"""

# %%
# Simulated data and random object splits
# ---------------------------------------
# :func:`tzsl.datasets.synthetic_dataset_arrays` returns the class attribute rows ``K``, the class
# of every trial and the features ``X`` (trials x sensors x features). Each class is one object
# here. :func:`tzsl.evaluation.random_object_splits` draws the unseen test objects, their attribute
# rows mutually different, and leaves out of a split the attributes its training objects cannot
# teach.
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from tzsl.datasets import synthetic_dataset_arrays
from tzsl.evaluation import (
    bootstrap_accuracy_columns,
    chance_accuracy,
    paired_difference_interval,
    random_object_splits,
)
from tzsl.models import build_method, get_method

K, cls, X = synthetic_dataset_arrays(480, n_classes=30, n_attributes=12, n_sensors=2, n_features=8, seed=1)
objects = np.array([f"c{c:02d}" for c in range(len(K))])
table = pd.DataFrame(K, index=objects, columns=[f"a{j:02d}" for j in range(K.shape[1])])
splits = random_object_splits(table, n_test=6, n_splits=4, random_state=0, min_train_positives=2)
print(f"{len(X)} trials, {len(K)} classes, {K.shape[1]} attributes, {len(splits)} splits")

# %%
# Fit every method on every split
# -------------------------------
# The methods see the training objects' trials and attribute rows only. At test time they rank
# the *unseen* classes, given as attribute rows. These methods take one feature vector per trial,
# so the two sensors are put side by side.
methods = ["eszsl", "sae", "iap", "ale"]
for name in methods:
    print(f"{name}: {get_method(name).paper}")

X_flat = X.reshape(len(X), -1)
correct, test_class, test_split = [], [], []
for k, split in enumerate(splits):
    cols = [table.columns.get_loc(a) for a in split.kept_attributes]
    train = np.isin(objects[cls], split.train_objects)
    test = np.isin(objects[cls], split.test_objects)
    unseen = np.flatnonzero(np.isin(objects, split.test_objects))  # candidate classes
    truth = np.searchsorted(unseen, cls[test])                      # row of each test trial's class
    hits = []
    for name in methods:
        model = build_method(name, random_state=0)
        model.fit(X_flat[train], K[cls[train]][:, cols], groups=cls[train])
        hits.append(model.predict(X_flat[test], class_attributes=K[unseen][:, cols]) == truth)
    correct.append(np.column_stack(hits))
    test_class.append(cls[test])
    test_split.append(np.full(test.sum(), k))
correct, test_class, test_split = np.vstack(correct), np.concatenate(test_class), np.concatenate(test_split)

# %%
# Accuracy with its interval, and paired differences
# --------------------------------------------------
# The interval resamples splits, then test classes with all their trials
# (:func:`tzsl.evaluation.bootstrap_accuracy_columns`). The paired difference resamples the same
# splits and classes for both methods (:func:`tzsl.evaluation.paired_difference_interval`): an
# interval that excludes 0 says the two methods differ on these data, even where their own
# intervals overlap.
mean, low, high = bootstrap_accuracy_columns(correct.astype(float), classes=test_class, splits=test_split)
chance = chance_accuracy(splits[0].n_test)
reference = methods[0]
rows = []
for j, name in enumerate(methods):
    diff = paired_difference_interval(correct[:, j], correct[:, 0], classes=test_class, splits=test_split)
    rows.append({"method": name, "accuracy": mean[j], "ci95_low": low[j], "ci95_high": high[j],
                 f"minus {reference}": diff[0], "diff_ci95_low": diff[1], "diff_ci95_high": diff[2]})
result = pd.DataFrame(rows)
print(result.round(3).to_string(index=False))
print(f"chance: {chance:.3f} (data: SIMULATED)")

# %%
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8, 3.5), sharey=True)
y = np.arange(len(methods))
ax1.errorbar(result["accuracy"], y, xerr=[result["accuracy"] - result["ci95_low"],
                                          result["ci95_high"] - result["accuracy"]], fmt="o", capsize=4)
ax1.axvline(chance, color="grey", linestyle="--", label="chance")
ax1.set_xlim(0, 1)
ax1.set_yticks(y, methods)
ax1.set_xlabel("accuracy, 95% interval")
ax1.legend(loc="lower right")
d = result[f"minus {reference}"]
ax2.errorbar(d, y, xerr=[d - result["diff_ci95_low"], result["diff_ci95_high"] - d], fmt="o", capsize=4)
ax2.axvline(0, color="grey")
ax2.set_xlabel(f"paired difference to {reference}")
fig.suptitle("Method comparison on SIMULATED data")
fig.tight_layout()
plt.show()
