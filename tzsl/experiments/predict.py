"""Classify new grasps with a saved model bundle, grasp by grasp, with multi-grasp fusion.

This is the engine of ``tzsl predict``. A model bundle (:mod:`tzsl.bundle`) holds a fitted
attribute model; a *class table* (``classes.csv``) lists the candidate classes by their
attributes; every input file holds one or more *grasps*. Each grasp is classified by DAP
(eq. 3) over the classes, and with several grasps the decision is fused:

* **SC-MDAP** (default, ``mode="sc"``): classify grasp by grasp, in the order given, and stop at
  the first class decided ``k`` times (DAP paper section 5.7.3). If no class reaches ``k`` the
  result says it has *not* decided (and names the most frequent class).
* **DF-MDAP** (``mode="df"``): average the grasps' attribute posteriors into one "super grasp"
  (eqs. 11-12) and classify it; the running decision after each grasp is reported too.

Model kinds plug in through a small adapter (:class:`ModelAdapter`) that turns input files into
per-grasp attribute posteriors; :data:`ADAPTERS` maps a bundle kind to its adapter and
:func:`register_adapter` adds one (e.g. a deep model). Two are built in:

``hand-dap`` (:class:`HandAdapter`)
    A :class:`tzsl.models.HandDAPClassifier` fitted by ``tzsl train-hand``. Inputs are grasp
    ``.npz`` files in the grasp format (``data/README.md``) or grasp folders. Single grasps use the
    model's fusion (MAXDAP / AVGDAP / LDAP); DF-MDAP averages LDAP posteriors (eqs. 11-12).
    Grasps in which no BioTac touched are skipped with a note (the paper drops them).
    Metadata: see :func:`hand_bundle_metadata`.
``phac2-dap`` (:class:`Phac2Adapter`)
    An attribute model with ``predict_proba(X (n, s, d)) -> (n, s, m)``, e.g. a fitted
    :class:`tzsl.models.AttributeClassifierBank`, saved by ``tzsl train-attributes --save``.
    Inputs are feature tables written by ``tzsl extract --out`` (``.csv`` or ``.npz``); every trial
    row is one grasp of the 2-finger gripper, sensors = the BioTacs. Posteriors are fused over
    sensors with MAXDAP (eq. 5) or AVGDAP (eq. 6); DF-MDAP averages the fused posteriors over
    trials (PHAC-2 trials explore the whole object, so there is no local-view ``max(0.5, p)``).
    Metadata (:data:`PHAC2_METADATA_KEYS`, built by :func:`phac2_bundle_metadata`):

    ``attribute_names``: list of m str, the model's attribute axis, in order;
    ``sensors``: list of s str, the feature table's sensors, in the model's order;
    ``feature_names``: list of d str, the feature columns, in the model's order;
    ``fusion``: ``"avg"`` or ``"max"``;
    ``prior``: ``"uni"``, ``"test"`` (mean of the class table's rows) or a list of m floats
    ``p(a_m = 1)`` (e.g. the training prior).

Class table (``classes.csv``): first column the class name (any header), then one 0/1 column per
attribute, named exactly as the model's attributes (a missing or unknown attribute is an error).
Lines starting with ``#`` are comments, and columns named ``split`` or ``subset`` are descriptive
and not used - so the shipped Table 4 file (``tzsl/datasets/hand_table4.csv``) works as is.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.special import softmax

from tzsl._io import read_npz
from tzsl.bundle import load_bundle, save_bundle
from tzsl.datasets import HandTable, read_grasps
from tzsl.datasets._feature_table import read_feature_table
from tzsl.datasets._grasps import grasp_from_arrays
from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError
from tzsl.experiments.hand import HandStudyConfig, feature_params, fit_hand_model, hand_features
from tzsl.features import GraspFeatures, grasp_features
from tzsl.models import (
    HandDAPClassifier,
    attribute_prior,
    dap_log_scores,
    fuse_attribute_posteriors,
    fuse_grasp_posteriors,
    sc_mdap,
)

__all__ = [
    "ADAPTERS",
    "HAND_KIND",
    "PHAC2_KIND",
    "PHAC2_METADATA_KEYS",
    "GraspPosteriors",
    "HandAdapter",
    "ModelAdapter",
    "Phac2Adapter",
    "Prediction",
    "format_prediction",
    "hand_bundle_metadata",
    "load_adapter",
    "phac2_bundle_metadata",
    "predict_grasps",
    "read_class_table",
    "register_adapter",
    "save_phac2_bundle",
    "top_ties",
    "train_hand_bundle",
]

HAND_KIND = "hand-dap"
PHAC2_KIND = "phac2-dap"
PHAC2_METADATA_KEYS: tuple[str, ...] = ("attribute_names", "sensors", "feature_names", "fusion", "prior")
HAND_METADATA_KEYS: tuple[str, ...] = ("attribute_names", "material_attributes", "feature_params")
_DESCRIPTIVE = ("split", "subset")


# ---------------------------------------------------------------------------- class table
def read_class_table(path: str | Path, attribute_names: Sequence[str]) -> pd.DataFrame:
    """Read candidate classes and check their attributes against the model's.

    Parameters
    ----------
    path : str or Path
        CSV file: class name in the first column, then 0/1 attribute columns (format in the
        module docstring).
    attribute_names : sequence of str
        The model's attributes, in the model's order.

    Returns
    -------
    DataFrame of shape (n_classes, n_attributes), int 0/1
        Indexed by class name, columns in ``attribute_names`` order.

    Raises
    ------
    DataFileError
        Missing file, missing or unknown attribute columns, non-0/1 entries, duplicate or empty
        class names (naming the file, the class and the attribute).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataFileError(path, "class table not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read the class table ({exc})") from None
    body = "\n".join(line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#"))
    try:
        table = pd.read_csv(StringIO(body), dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise DataFileError(path, f"cannot parse the class table: {exc}") from None
    if table.shape[1] < 2 or table.empty:
        raise DataFileError(path, "a class table needs a class-name column, attribute columns and at least one row")
    name_col = table.columns[0]
    names = table[name_col].str.strip()
    if (names == "").any():
        raise DataFileError(path, f"empty class name on row(s) {list(np.flatnonzero(names == '') + 2)}")
    if names.duplicated().any():
        raise DataFileError(path, f"duplicate class name(s) {sorted(set(names[names.duplicated()]))}")
    given = [c for c in table.columns[1:] if c not in _DESCRIPTIVE]
    wanted = [str(a) for a in attribute_names]
    missing = [a for a in wanted if a not in given]
    unknown = [a for a in given if a not in wanted]
    if missing or unknown:
        parts = []
        if missing:
            parts.append(f"missing attribute column(s) {missing}")
        if unknown:
            parts.append(f"unknown attribute column(s) {unknown}")
        raise DataFileError(path, "; ".join(parts) + f"; the model's attributes are {wanted}")
    values = table[wanted].apply(lambda c: c.str.strip())
    bad = ~values.isin(["0", "1"])
    if bad.any().any():
        r, c = np.argwhere(bad.to_numpy())[0]
        raise DataFileError(
            path, f"class {names.iloc[r]!r}, attribute {wanted[c]!r}: value {values.iat[r, c]!r} is not 0 or 1"
        )
    return pd.DataFrame(values.to_numpy(dtype=int), index=pd.Index(names, name="class"), columns=wanted)


# ---------------------------------------------------------------------------- adapters
@dataclass
class GraspPosteriors:
    """Attribute posteriors of the grasps read from the input files.

    Attributes
    ----------
    grasp_ids, sources, info : list of str, length n
        Id, file and a short description of every grasp kept.
    present, absent : ndarray of shape (n, m)
        ``p(a_m = 1 | x)`` and ``p(a_m = 0 | x)`` of every grasp, for single-grasp DAP and SC-MDAP.
    df_present, df_absent : ndarray of shape (n, m)
        The per-grasp posteriors DF-MDAP averages over grasps.
    notes : list of str
        Grasps skipped and why.
    """

    grasp_ids: list[str]
    sources: list[str]
    info: list[str]
    present: np.ndarray
    absent: np.ndarray
    df_present: np.ndarray
    df_absent: np.ndarray
    notes: list[str] = field(default_factory=list)


class ModelAdapter(ABC):
    """Turns input files into per-grasp attribute posteriors for one kind of saved model.

    Parameters
    ----------
    model : object
        The unpickled model.
    metadata : dict
        The bundle's metadata.
    """

    kind: str = ""
    inputs: str = "input files"

    def __init__(self, model: Any, metadata: dict) -> None:
        self.model = model
        self.metadata = metadata

    def _require(self, keys: Sequence[str]) -> None:
        missing = [k for k in keys if k not in self.metadata]
        if missing:
            raise ModelBundleError(f"{self._where()}: {self.kind} bundle metadata lacks {missing}")

    def _where(self) -> str:
        return self.metadata.get("bundle", {}).get("path", "model bundle")

    @property
    @abstractmethod
    def attribute_names(self) -> list[str]:
        """The model's attributes, in the order of the posterior columns."""

    @abstractmethod
    def posteriors(self, inputs: Sequence[str | Path]) -> GraspPosteriors:
        """Posteriors of every grasp in ``inputs``, in file order."""

    @abstractmethod
    def prior(self, K: np.ndarray) -> np.ndarray:
        """Attribute prior ``p(a_m = 1)``, shape (m,), given the candidate classes ``K`` (c, m)."""

    def describe(self) -> str:
        """One line naming the model."""
        return f"{self.kind} model, {len(self.attribute_names)} attributes"

    def class_scores(self, present: np.ndarray, absent: np.ndarray, K: np.ndarray) -> np.ndarray:
        """Log-scores (n, c) of the candidate classes ``K`` (c, m); DAP (eq. 3) unless overridden.

        ``present`` / ``absent`` are per-grasp ``p(a_m = 1 | x)`` / ``p(a_m = 0 | x)``, shape (n, m),
        or their running means over grasps for DF-MDAP.
        """
        return dap_log_scores(present, K, self.prior(K), P_absent=absent)


def _read_grasp_inputs(inputs: Sequence[str | Path]) -> list:
    grasps = []
    for item in inputs:
        path = Path(item)
        if path.is_dir():
            grasps += read_grasps(path)
            continue
        if path.suffix != ".npz":
            raise DataFileError(path, "a hand-model input must be a grasp .npz file or a grasp folder")
        if not path.is_file():
            raise DataFileError(path, "grasp file not found")
        arrays = read_npz(path)
        grasps.append(grasp_from_arrays(arrays, path.stem, "", str(path)))
    return grasps


class HandAdapter(ModelAdapter):
    """``hand-dap`` bundles: :class:`~tzsl.models.HandDAPClassifier` on grasp ``.npz`` files."""

    kind = HAND_KIND
    inputs = "grasp .npz files or grasp folders"

    def __init__(self, model: Any, metadata: dict) -> None:
        super().__init__(model, metadata)
        self._require(HAND_METADATA_KEYS)
        if not isinstance(model, HandDAPClassifier) or not hasattr(model, "K_"):
            raise ModelBundleError(f"{self._where()}: a hand-dap bundle must hold a fitted HandDAPClassifier, "
                                   f"found {type(model).__name__}")
        if list(model.K_.columns) != list(metadata["attribute_names"]):
            raise ModelBundleError(f"{self._where()}: metadata attribute_names differ from the model's")

    @property
    def attribute_names(self) -> list[str]:
        return list(self.model.K_.columns)

    def describe(self) -> str:
        return (f"hand-dap model (HandDAPClassifier, fusion {self.model.fusion.upper()}), "
                f"{len(self.attribute_names)} attributes, trained on {list(self.model.classes_)}")

    def posteriors(self, inputs: Sequence[str | Path]) -> GraspPosteriors:
        grasps = _read_grasp_inputs(inputs)
        if not grasps:
            raise DataFileError(None, "no grasps given")
        feats: GraspFeatures = grasp_features(grasps, **self.metadata["feature_params"])
        touched = feats.contact.any(axis=1)
        notes = [f"skipped grasp {g} ({s}): no BioTac touched the object"
                 for g, s, t in zip(feats.grasp_ids, [g.source for g in grasps], touched, strict=True) if not t]
        if not touched.any():
            raise DataFileError(None, "no grasp with a touching BioTac: nothing to classify")
        kept = feats.subset(touched)
        P_mat, contact, P_sh = self.model.attribute_posteriors(kept.to_array())
        present = fuse_grasp_posteriors(P_mat, contact, P_sh, self.model.fusion)
        ldap = fuse_grasp_posteriors(P_mat, contact, P_sh, "ldap")
        sources = [g.source for g, t in zip(grasps, touched, strict=True) if t]
        info = [f"{int(b)} BioTac(s) touching" for b in kept.n_contacts]
        return GraspPosteriors(list(kept.grasp_ids), sources, info, present, 1.0 - present, ldap, 1.0 - ldap, notes)

    def prior(self, K: np.ndarray) -> np.ndarray:
        return np.full(K.shape[1], float(self.model.prior))


class Phac2Adapter(ModelAdapter):
    """``phac2-dap`` bundles: a per-sensor attribute model on ``tzsl extract`` feature tables."""

    kind = PHAC2_KIND
    inputs = "feature tables (.csv / .npz) written by 'tzsl extract --out'"

    def __init__(self, model: Any, metadata: dict) -> None:
        super().__init__(model, metadata)
        self._require(PHAC2_METADATA_KEYS)
        if not hasattr(model, "predict_proba"):
            raise ModelBundleError(f"{self._where()}: a phac2-dap bundle must hold an attribute model with "
                                   f"predict_proba, found {type(model).__name__}")
        if metadata["fusion"] not in ("avg", "max"):
            raise ModelBundleError(f"{self._where()}: fusion must be 'avg' or 'max', found {metadata['fusion']!r}")
        prior = metadata["prior"]
        m = len(metadata["attribute_names"])
        if not (prior in ("uni", "test") or (isinstance(prior, list) and len(prior) == m)):
            raise ModelBundleError(f"{self._where()}: prior must be 'uni', 'test' or a list of {m} probabilities")

    @property
    def attribute_names(self) -> list[str]:
        return [str(a) for a in self.metadata["attribute_names"]]

    def describe(self) -> str:
        prior = self.metadata["prior"]
        prior = prior if isinstance(prior, str) else "as saved (e.g. training)"
        return (f"phac2-dap model ({type(self.model).__name__}, {self.metadata['fusion'].upper()}DAP over "
                f"{len(self.metadata['sensors'])} sensors, prior {prior}), {len(self.attribute_names)} attributes")

    def _features(self, path: Path) -> tuple[np.ndarray, list[str]]:
        table = read_feature_table(path)
        sensors, names = list(self.metadata["sensors"]), list(self.metadata["feature_names"])
        missing_s = [s for s in sensors if s not in table.sensors]
        if missing_s:
            raise DataFileError(path, f"sensor(s) {missing_s} missing; the model needs sensors {sensors}, "
                                      f"the table has {list(table.sensors)}")
        missing_f = [f for f in names if f not in table.feature_names]
        if missing_f:
            raise DataFileError(path, f"{len(missing_f)} feature column(s) the model needs are missing, e.g. "
                                      f"{missing_f[:5]}; extract the features with the settings used for training")
        s_idx = [list(table.sensors).index(s) for s in sensors]
        f_idx = [list(table.feature_names).index(f) for f in names]
        X = table.X[:, s_idx][:, :, f_idx]
        return X, [str(t) for t in table.trials["trial_id"]]

    def posteriors(self, inputs: Sequence[str | Path]) -> GraspPosteriors:
        Xs, ids, sources = [], [], []
        for item in inputs:
            X, trial_ids = self._features(Path(item))
            Xs.append(X)
            ids += trial_ids
            sources += [str(item)] * len(trial_ids)
        if not Xs:
            raise DataFileError(None, "no feature table given")
        X = np.concatenate(Xs)
        P = np.asarray(self.model.predict_proba(X), dtype=float)
        m = len(self.attribute_names)
        if P.shape != (X.shape[0], X.shape[1], m):
            raise ModelBundleError(f"{self._where()}: the model returned posteriors of shape {P.shape}, "
                                   f"expected {(X.shape[0], X.shape[1], m)} (trials, sensors, attributes)")
        present, absent = fuse_attribute_posteriors(P, self.metadata["fusion"])
        info = [f"{X.shape[1]} sensors"] * X.shape[0]
        return GraspPosteriors(ids, sources, info, present, absent, present, absent)

    def prior(self, K: np.ndarray) -> np.ndarray:
        prior = self.metadata["prior"]
        if prior == "uni":
            return np.full(K.shape[1], 0.5)
        if prior == "test":
            return attribute_prior("test", class_attributes=K)
        return attribute_prior(np.asarray(prior, dtype=float))


class DeepAdapter(ModelAdapter):
    """``deep`` bundles: the CNN + LSTM attribute embedding on press videos or key-frame arrays.

    An input is a video file (``.avi`` etc.; 5 key frames are selected with
    :class:`tzsl.features.KeyFrameSelector`) or an ``.npz`` holding ``frames`` of shape
    (5, H, W[, C]). The model's "posteriors" are its attribute estimates ``f(x)`` in (0, 1);
    classes are scored by ``-||f - a_c||^2`` (nearest attribute vector, fabric paper section 4.2),
    and DF-MDAP averages ``f`` over grasps before scoring.
    """

    kind = "deep"
    inputs = "press videos (.avi) or .npz files with a 'frames' array (5, H, W[, C])"

    @property
    def attribute_names(self) -> list[str]:
        names = self.metadata.get("attribute_names")
        if names is None:
            names = [f"attr_{j}" for j in range(int(self.model.n_attributes_))]
        return [str(a) for a in names]

    def _frames(self, path: Path) -> np.ndarray:
        if not path.is_file():
            raise DataFileError(path, "input file not found")
        if path.suffix == ".npz":
            arrays = read_npz(path)
            if "frames" not in arrays:
                raise DataFileError(path, f"no 'frames' array (found {list(arrays)})")
            return np.asarray(arrays["frames"])
        from tzsl.features import KeyFrameSelector  # noqa: PLC0415

        return KeyFrameSelector().transform([str(path)])[0]

    def posteriors(self, inputs: Sequence[str | Path]) -> GraspPosteriors:
        if not inputs:
            raise DataFileError(None, "no input given")
        paths = [Path(p) for p in inputs]
        frames = [self._frames(p) for p in paths]
        shapes = {f.shape for f in frames}
        if len(shapes) != 1:
            raise DataFileError(None, f"inputs have different frame shapes {sorted(shapes)}")
        F = np.asarray(self.model.transform(np.stack(frames)), dtype=float)
        info = [f"{f.shape[0]} key frames" for f in frames]
        return GraspPosteriors([p.stem for p in paths], [str(p) for p in paths], info, F, 1.0 - F, F, 1.0 - F)

    def prior(self, K: np.ndarray) -> np.ndarray:  # not used by the nearest-attribute rule
        return np.full(K.shape[1], 0.5)

    def class_scores(self, present: np.ndarray, absent: np.ndarray, K: np.ndarray) -> np.ndarray:
        return -((present[:, None, :] - K[None, :, :]) ** 2).sum(axis=2)


def _deep_adapter(model: Any, metadata: dict) -> DeepAdapter:
    return DeepAdapter(model, metadata)


#: Bundle kind -> adapter class (or any callable ``(model, metadata) -> ModelAdapter``).
ADAPTERS: dict[str, Callable[[Any, dict], ModelAdapter]] = {
    HAND_KIND: HandAdapter, PHAC2_KIND: Phac2Adapter, "deep": _deep_adapter,
}


def register_adapter(kind: str, factory: Callable[[Any, dict], ModelAdapter]) -> None:
    """Make ``tzsl predict`` understand bundles of ``kind`` (e.g. ``"deep"``)."""
    ADAPTERS[kind] = factory


def load_adapter(path: str | Path, *, trust_pickle: bool = False) -> ModelAdapter:
    """Load a bundle (see :func:`tzsl.bundle.load_bundle`; no code is run) and wrap it.

    ``trust_pickle=True`` also loads old (format version 1) pickle bundles, which can run code:
    only for files whose author you trust.

    Raises
    ------
    ModelBundleError
        Unreadable / corrupt / foreign bundle, or a kind no adapter handles.
    """
    from tzsl.bundle import read_bundle_header  # noqa: PLC0415

    kind = read_bundle_header(path).kind  # verified, nothing deserialised yet
    if kind not in ADAPTERS:
        raise ModelBundleError(f"{path}: no predictor for bundles of kind {kind!r} (known: {sorted(ADAPTERS)})")
    if kind == "deep":
        from tzsl.models._deep import load_deep_bundle  # noqa: PLC0415 - needs the deep extra

        model = load_deep_bundle(path, trust_pickle=trust_pickle)
        metadata = dict(read_bundle_header(path).metadata)
        return ADAPTERS[kind](model, metadata)
    model, metadata = load_bundle(path, expected_kind=kind, trust_pickle=trust_pickle)
    return ADAPTERS[kind](model, metadata)


# ---------------------------------------------------------------------------- prediction
@dataclass
class Prediction:
    """Result of :func:`predict_grasps`.

    Attributes
    ----------
    classes : list of str, length c
    grasp_ids, sources, info : list of str, length n
    grasp_posteriors : ndarray of shape (n, c)
        ``p(z | x)`` of every grasp alone (DAP, normalised over the candidate classes).
    decisions : ndarray of int, shape (n,)
        Per-grasp top class (index into ``classes``).
    mode : {"sc", "df"}
    k : int
        SC-MDAP's number of equal classifications.
    decided : bool
        SC-MDAP: some class reached ``k``; DF-MDAP: always True.
    n_used : int
        Grasps used for the decision.
    final : int
        Decided class (SC-MDAP undecided: the most frequent class, ties to the earliest).
    final_posteriors : ndarray of shape (c,) or None
        DF-MDAP: ``p(z | super grasp)``.
    running : ndarray of int, shape (n,) or None
        DF-MDAP: decision after the first 1, 2, ..., n grasps.
    notes : list of str
    """

    classes: list[str]
    grasp_ids: list[str]
    sources: list[str]
    info: list[str]
    grasp_posteriors: np.ndarray
    decisions: np.ndarray
    mode: str
    k: int
    decided: bool
    n_used: int
    final: int
    final_posteriors: np.ndarray | None = None
    running: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)


def predict_grasps(
    adapter: ModelAdapter, classes: pd.DataFrame, inputs: Sequence[str | Path], *, mode: str = "sc", k: int = 3
) -> Prediction:
    """Classify the grasps in ``inputs`` among ``classes`` and fuse them (SC-MDAP or DF-MDAP).

    Parameters
    ----------
    adapter : ModelAdapter
    classes : DataFrame of shape (c, m)
        From :func:`read_class_table` (columns in the adapter's attribute order).
    inputs : sequence of paths
        In arrival order.
    mode : {"sc", "df"}
    k : int
        Equal classifications SC-MDAP needs.
    """
    if mode not in ("sc", "df"):
        raise ConfigError(f"fusion mode must be 'sc' (SC-MDAP) or 'df' (DF-MDAP), got {mode!r}")
    if not isinstance(k, int | np.integer) or k < 1:
        raise ConfigError(f"k must be a positive integer, got {k!r}")
    if list(classes.columns) != adapter.attribute_names:
        raise ConfigError("class table columns are not in the model's attribute order; read it with read_class_table")
    K = classes.to_numpy(dtype=float)
    post = adapter.posteriors(inputs)
    scores = adapter.class_scores(post.present, post.absent, K)
    grasp_p = softmax(scores, axis=1)
    decisions = scores.argmax(axis=1)
    n = len(decisions)
    final_p = running = None
    if mode == "sc":
        d, used, ok = sc_mdap(decisions[None, :], int(k))
        final, n_used, decided = int(d[0]), int(used[0]), bool(ok[0])
    else:
        steps = np.arange(1, n + 1)[:, None]
        cum_p = np.cumsum(post.df_present, axis=0) / steps  # (n, m): super grasp of the first t grasps
        cum_a = np.cumsum(post.df_absent, axis=0) / steps
        run_scores = adapter.class_scores(cum_p, cum_a, K)
        running = run_scores.argmax(axis=1)
        final_p = softmax(run_scores[-1])
        final, n_used, decided = int(running[-1]), n, True
    return Prediction(
        classes=[str(c) for c in classes.index], grasp_ids=list(post.grasp_ids), sources=list(post.sources),
        info=list(post.info), grasp_posteriors=grasp_p, decisions=decisions, mode=mode, k=int(k),
        decided=decided, n_used=n_used, final=final, final_posteriors=final_p, running=running,
        notes=list(post.notes),
    )


def top_ties(p: np.ndarray) -> np.ndarray:
    """Indices of the classes whose posterior equals the top one (up to rounding), shape (t,)."""
    return np.flatnonzero(np.isclose(p, p.max(), rtol=1e-9, atol=1e-12))


def _ranking(p: np.ndarray, classes: list[str], top: int) -> list[str]:
    order = np.argsort(-p, kind="stable")[: top if top > 0 else None]
    width = max(len(c) for c in classes)
    lines = [f"  {r + 1:>3}. {classes[i]:<{width}}  {p[i]:.3f}" for r, i in enumerate(order)]
    tied = top_ties(p)
    if tied.size > 1:
        lines.append(f"       tie at the top: {', '.join(classes[i] for i in tied)} have equal posteriors "
                     "(the evidence cannot tell them apart; the listed first is an arbitrary pick)")
    return lines


def format_prediction(pred: Prediction, top: int = 5) -> str:
    """Human-readable report: each grasp's ranked classes, then the multi-grasp decision."""
    lines = [f"note: {n}" for n in pred.notes]
    n = len(pred.grasp_ids)
    for i in range(n):
        lines.append(f"grasp {i + 1}/{n}: {pred.grasp_ids[i]} ({pred.sources[i]}; {pred.info[i]})")
        lines += _ranking(pred.grasp_posteriors[i], pred.classes, top)
    name = lambda j: repr(pred.classes[int(j)])  # noqa: E731
    if pred.mode == "sc":
        seq = ", ".join(pred.classes[int(d)] for d in pred.decisions)
        lines.append(f"per-grasp decisions: {seq}")
        if pred.decided:
            lines.append(f"SC-MDAP (k={pred.k}): decided {name(pred.final)} after grasp {pred.n_used} of {n} "
                         f"({pred.k} equal classification{'s' if pred.k > 1 else ''})")
        else:
            count = int((pred.decisions == pred.final).sum())
            lines.append(f"SC-MDAP (k={pred.k}): NOT decided after {n} grasp{'s' if n > 1 else ''}: no class reached "
                         f"{pred.k} equal classifications (most frequent so far: {name(pred.final)}, {count} of {n})")
    else:
        seq = ", ".join(pred.classes[int(d)] for d in pred.running)
        lines.append(f"DF-MDAP decision after each grasp: {seq}")
        lines.append(f"DF-MDAP: decided {name(pred.final)} from all {n} grasp{'s' if n > 1 else ''} (eqs. 11-12):")
        lines += _ranking(pred.final_posteriors, pred.classes, top)
    return "\n".join(lines)


# ---------------------------------------------------------------------------- saving
def hand_bundle_metadata(model: HandDAPClassifier, table: HandTable, features_kw: dict, **extra) -> dict:
    """Metadata of a ``hand-dap`` bundle: attributes, feature settings and provenance."""
    return {
        "attribute_names": list(model.K_.columns),
        "material_attributes": list(model.material_attributes_),
        "shape_attributes": list(model.shape_attributes_),
        "feature_params": dict(features_kw),
        "training_objects": [str(c) for c in model.classes_],
        "fusion": model.fusion,
        "prior": float(model.prior),
        "class_table": table.source,
        **extra,
    }


def train_hand_bundle(
    grasps_dir: str | Path,
    table: HandTable,
    save: str | Path,
    *,
    fusion: str = "ldap",
    seed: int = 0,
    config: HandStudyConfig | None = None,
    force: bool = False,
) -> tuple[HandDAPClassifier, dict]:
    """Fit the hand model on the training objects' grasps of a grasp folder and save a bundle.

    Returns
    -------
    model : HandDAPClassifier
    metadata : dict
        As saved, plus ``n_training_grasps`` and ``n_ignored_grasps`` (grasps of other objects).
    """
    config = HandStudyConfig() if config is None else config
    save = Path(save)
    if save.exists() and not force:
        raise ConfigError(f"{save} already exists; use --force to overwrite it")
    grasps = read_grasps(grasps_dir)
    features = hand_features(grasps, table, config)
    model = fit_hand_model(features, table, config, seed, fusion=fusion)
    n_train = int(np.isin(features.objects, table.train_objects).sum())
    metadata = hand_bundle_metadata(
        model, table, feature_params(config), grasps=str(grasps_dir), seed=int(seed),
        n_training_grasps=n_train, n_ignored_grasps=len(features) - n_train,
    )
    save_bundle(save, model, kind=HAND_KIND, metadata=metadata, force=force)
    return model, metadata


def phac2_bundle_metadata(
    features, *, fusion: str, prior: str | Sequence[float] | np.ndarray, **extra
) -> dict:
    """Metadata of a ``phac2-dap`` bundle for a model fitted on ``features`` (a FeatureSet).

    Parameters
    ----------
    features : FeatureSet
        The training features (their sensors, feature names and attribute columns define the
        layout the model expects).
    fusion : {"avg", "max"}
    prior : "uni", "test" or array-like of shape (m,)
        E.g. ``attribute_prior("train", train_attributes=..., groups=...)``.
    **extra
        Further JSON-serialisable provenance (training objects, split, seed, ...).
    """
    if fusion not in ("avg", "max"):
        raise ConfigError(f"fusion must be 'avg' or 'max', got {fusion!r}")
    m = features.attributes.shape[1]
    if isinstance(prior, str):
        if prior not in ("uni", "test"):
            raise ConfigError("prior must be 'uni', 'test' or the prior vector itself (e.g. the training prior)")
        prior_value: Any = prior
    else:
        prior_value = [float(p) for p in attribute_prior(np.asarray(prior, dtype=float))]
        if len(prior_value) != m:
            raise ConfigError(f"prior has {len(prior_value)} entries for {m} attributes")
    return {
        "attribute_names": [str(a) for a in features.attributes.columns],
        "sensors": [str(s) for s in features.sensors],
        "feature_names": [str(f) for f in features.feature_names],
        "fusion": fusion,
        "prior": prior_value,
        "dataset": features.dataset,
        **extra,
    }


def save_phac2_bundle(path: str | Path, model: Any, features, *, fusion: str, prior, force: bool = False,
                      **extra) -> Path:
    """Save a fitted PHAC-2 attribute model (e.g. AttributeClassifierBank) as a ``phac2-dap`` bundle.

    ``model.predict_proba(X)`` must map ``(n, s, d)`` features laid out as ``features`` to
    ``(n, s, m)`` posteriors of ``features.attributes.columns``.
    """
    metadata = phac2_bundle_metadata(features, fusion=fusion, prior=prior, **extra)
    return save_bundle(path, model, kind=PHAC2_KIND, metadata=metadata, force=force)
