"""
Choosing the next exploratory procedure
=======================================

A robot pays for every exploratory procedure (EP: squeeze, hold, slow slide, fast slide) in
seconds. A per-EP model (:class:`tzsl.models.PerEPAttributeModel`) holds one attribute model per
EP and how much each EP confuses each attribute (estimated by object-grouped cross-validation on
the training objects only). After each EP, :func:`tzsl.models.active_touch.suggest_next_ep` updates the
posterior over the candidate classes, says whether it has decided, and which EP to do next: the
one with the largest expected reduction of the class entropy.

The touch data are **simulated**: each EP sees a different noisy view of the object's attributes.
Every number below comes from this simulation.
"""

# %%
# Simulated per-EP features
# -------------------------
# Features are named ``<ep>:<feature>``, as tzsl names PHAC-2's (``tzsl extract``);
# :func:`tzsl.models.active_touch.ep_column_blocks` finds each EP's columns from the names. Here each EP gets
# its own block of simulated features with its own noise level, so some EPs tell more than others.
import json

import matplotlib.pyplot as plt
import numpy as np

from tzsl.datasets import synthetic_dataset_arrays
from tzsl.models import PerEPAttributeModel
from tzsl.models.active_touch import PHAC2_EP_SECONDS, ep_column_blocks, suggest_next_ep

eps = list(PHAC2_EP_SECONDS)  # the EP names and durations (seconds) of the PHAC-2 robot
n_classes, n_features = 24, 6
# One simulated "sensor" per EP: each has its own non-linear view of the attributes.
K, cls, X_views = synthetic_dataset_arrays(480, n_classes=n_classes, n_attributes=10, n_sensors=len(eps),
                                           n_features=n_features, seed=0)
# Extra noise makes the EPs unequally informative (the cheap fast slide the noisiest).
extra_noise = dict(zip(eps, [0.0, 0.5, 1.0, 2.0], strict=True))
rng = np.random.default_rng(0)
X_views = X_views + np.array([extra_noise[ep] for ep in eps])[None, :, None] * rng.normal(size=X_views.shape)
X = X_views.reshape(len(X_views), 1, -1)  # (n_trials, 1 sensor, 4 EPs x 6 features)
names = [f"{ep}:f{j}" for ep in eps for j in range(n_features)]
ep_columns = ep_column_blocks(names)
print({ep: cols.tolist() for ep, cols in ep_columns.items()})

# %%
# Fit on the training objects
# ---------------------------
# Each class is one object. The first 18 objects train; the other 6 are the unseen candidates.
train_classes, unseen = np.arange(18), np.arange(18, n_classes)
train = np.isin(cls, train_classes)
model = PerEPAttributeModel(ep_columns=ep_columns, cv=3, random_state=0)
model.fit(X[train], K[cls[train]], groups=cls[train])

# %%
# One trial of an unseen object, EP by EP
# ---------------------------------------
# Start with the cheapest EP, then follow the suggestion until the top class reaches the
# threshold or no EP is left. ``suggest_next_ep`` returns a JSON-ready dict: the same object that
# ``tzsl predict --suggest-next --json`` prints for a robot.
trial = np.flatnonzero(cls == unseen[0])[0]
names_unseen = [f"c{c}" for c in unseen]
done = {}
next_ep = min(PHAC2_EP_SECONDS, key=PHAC2_EP_SECONDS.get)
history, order = [], []
while next_ep is not None:
    done[next_ep] = X[trial][:, ep_columns[next_ep]]
    order.append(next_ep)
    step = suggest_next_ep(model, K[unseen], done, class_names=names_unseen, threshold=0.9)
    history.append(step)
    top = step["ranking"][0]
    print(f"after {' + '.join(order)} ({step['seconds_used']:.0f} s): top {top['class']} "
          f"(p = {top['probability']:.3f}), decided={step['decided']}, next={step['next_ep']}")
    next_ep = step["next_ep"]
print("true class:", f"c{cls[trial]}")
print(json.dumps({k: history[-1][k] for k in ("decided", "decision", "stop_reason", "seconds_used")}))

# %%
# The posterior after each EP
# ---------------------------
# The posterior multiplies the EPs' evidence as if they were independent given the class, so it
# is over-confident; the threshold is a stopping rule, not a calibrated probability.
fig, ax = plt.subplots(figsize=(6, 3.5))
for name in names_unseen:
    p = [next(r["probability"] for r in step["ranking"] if r["class"] == name) for step in history]
    ax.plot(range(1, len(history) + 1), p, marker="o", label=name + (" (true)" if name == f"c{cls[trial]}" else ""))
ax.axhline(0.9, color="grey", linestyle="--", label="threshold")
ax.set_xticks(range(1, len(history) + 1), [("+ " if i else "") + ep for i, ep in enumerate(order)])
ax.set_ylabel("posterior")
ax.set_title("Active touch on SIMULATED data")
ax.legend(fontsize="small", ncol=2)
fig.tight_layout()
plt.show()
