"""Load a model bundle once and recognise grasps as they arrive: the Python API of ``tzsl predict``.

A robot loads its model once (:meth:`Recogniser.load`), then for every grasp asks for the ranked
candidate classes (:meth:`Recogniser.rank`), adds it to the object's evidence so the multi-grasp
decision updates (:meth:`Recogniser.add`: SC-MDAP or DF-MDAP, as ``tzsl predict --multi-grasp``),
and, with a per-EP bundle, asks which exploratory procedure to do next
(:meth:`Recogniser.suggest_next_ep`). ``tzsl predict`` runs on this class: the same grasps give
the same result from the command line and from Python.

Linear models (ESZSL, SAE, ALE, SJE, DeViSE: :mod:`tzsl.inference.linear_bundles`) and DAP
models (an attribute-detector bank + DAP rule: :mod:`tzsl.inference.detector_bundles`) load and
rank with numpy alone; other models import scikit-learn when loaded; no bundle but a deep one
imports torch.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tzsl._scoring import sc_mdap
from tzsl.exceptions import ConfigError, ModelBundleError
from tzsl.inference.bundle import read_bundle_header
from tzsl.inference.bundle_kinds import PER_EP_KIND, left_out_attributes
from tzsl.inference.predict import Prediction, read_class_table
from tzsl.inference.predict_inputs import grasp_model_input, read_inputs
from tzsl.inference.zero_shot_bundles import Predictor, load_predictor

__all__ = ["DEFAULT_FUSION", "DEFAULT_K", "FUSION_MODES", "Recogniser", "predict_grasps"]

#: Multi-grasp fusion modes: SC-MDAP (stop at ``k`` equal decisions) and DF-MDAP (average the grasps).
FUSION_MODES = ("sc", "df")
#: Default multi-grasp fusion mode (``tzsl predict --multi-grasp`` shows the same, checked by a test).
DEFAULT_FUSION = "sc"
#: Default number of equal classifications SC-MDAP needs (``tzsl predict --k``, the same).
DEFAULT_K = 3


class Recogniser:
    """A model bundle and a candidate class table, loaded once; grasps ranked and fused as they arrive.

    Build it with :meth:`load`. For zero-shot, hand and deep bundles: :meth:`rank` (one grasp
    alone), :meth:`add` (one more grasp of the current object; the fused decision so far),
    :meth:`reset` (a new object), :meth:`classify` (grasp files, as ``tzsl predict``). For
    per-EP bundles: :meth:`suggest_next_ep`.

    Parameters
    ----------
    classes : DataFrame of shape (n_classes, n_attributes), 0/1
        Candidate classes (:func:`~tzsl.inference.predict.read_class_table`: indexed by class
        name, columns in the model's attribute order).
    predictor : Predictor, optional
        A loaded zero-shot / hand / deep bundle (:func:`~tzsl.inference.zero_shot_bundles.load_predictor`).
    per_ep : tuple (model, metadata), optional
        A loaded per-EP bundle (:func:`~tzsl.inference.predict_active.load_per_ep_model`).
    mode : {"sc", "df"}, default DEFAULT_FUSION ("sc")
        Multi-grasp fusion of :meth:`add`: SC-MDAP (decided once ``k`` grasps agree) or DF-MDAP
        (the grasps' attribute scores averaged into one "super grasp").
    k : int >= 1, default DEFAULT_K (3)
        Equal classifications SC-MDAP needs.

    Attributes
    ----------
    classes : DataFrame of shape (n_classes, n_attributes)
    class_names : list of str, length n_classes
    attribute_names : list of str, length n_attributes
    kind : str
        The bundle's kind (``"zero-shot"``, ``"deep"``, ``"per-ep"``).
    predictor : Predictor or None
        The loaded model (None for a per-EP bundle); ``predictor.input`` is its feature schema
        (``sensors``, ``feature_names``: the order of a grasp's rows and columns).
    per_ep : tuple (PerEPAttributeModel, dict) or None
        The loaded per-EP model and its metadata (None for other bundles).
    mode, k
        As given.
    """

    def __init__(self, classes: pd.DataFrame, *, predictor: Predictor | None = None,
                 per_ep: tuple[Any, dict] | None = None, mode: str = DEFAULT_FUSION, k: int = DEFAULT_K) -> None:
        if (predictor is None) == (per_ep is None):
            raise ConfigError("a Recogniser needs one loaded bundle: a predictor or a per-EP model")
        if mode not in FUSION_MODES:
            raise ConfigError(f"fusion mode must be 'sc' (SC-MDAP) or 'df' (DF-MDAP), got {mode!r}")
        if not isinstance(k, int | np.integer) or isinstance(k, bool) or k < 1:
            raise ConfigError(f"k must be a positive integer, got {k!r}")
        self.predictor, self.per_ep, self.mode, self.k = predictor, per_ep, mode, int(k)
        if predictor is not None:
            names = predictor.attribute_names
        else:
            assert per_ep is not None  # exactly one of them (checked above)
            names = list(per_ep[1]["attribute_names"])
        self.attribute_names = [str(a) for a in names]
        if list(classes.columns) != self.attribute_names:
            raise ConfigError("class table columns are not in the model's attribute order; read it with "
                              "read_class_table")
        self.classes = classes
        self.class_names = [str(c) for c in classes.index]
        self._K = classes.to_numpy(dtype=float)
        self.kind = predictor.kind if predictor is not None else PER_EP_KIND
        self.reset()

    @classmethod
    def load(cls, model: str | Path, classes: str | Path, *, candidates: Sequence[str] | None = None,
             mode: str = DEFAULT_FUSION, k: int = DEFAULT_K, trust_pickle: bool = False) -> Recogniser:
        """Load a bundle and its candidate classes (``tzsl predict --model --classes --candidates``).

        Parameters
        ----------
        model : str or Path
            A bundle written by ``tzsl train-attributes`` (``--per-ep`` too), ``train-hand`` or
            ``train-deep``. Loading it runs no code (see :mod:`tzsl.inference.bundle`).
        classes : str or Path
            CSV (class name, then one 0/1 column per model attribute) or a dataset folder (its
            ``classes.csv``).
        candidates : sequence of str, optional
            Keep only these classes, in this order.
        mode, k
            Multi-grasp fusion (see the class).
        trust_pickle : bool, default False
            Also load an old (format 1) pickle bundle, which runs code: only a file you trust.

        Raises
        ------
        ModelBundleError, DataFileError, ConfigError
            One line naming the file and the problem.
        """
        if read_bundle_header(model).kind == PER_EP_KIND:
            from tzsl.inference.predict_active import load_per_ep_model  # noqa: PLC0415 - imports scikit-learn

            per_ep = load_per_ep_model(model, trust_pickle=trust_pickle)
            table = read_class_table(classes, per_ep[1]["attribute_names"], candidates=candidates,
                                     left_out=left_out_attributes(per_ep[1]))
            return cls(table, per_ep=per_ep, mode=mode, k=k)
        predictor = load_predictor(model, trust_pickle=trust_pickle)
        table = read_class_table(classes, predictor.attribute_names, candidates=candidates,
                                 left_out=left_out_attributes(predictor.metadata))
        return cls(table, predictor=predictor, mode=mode, k=k)

    # ------------------------------------------------------------------ one grasp
    def _predictor(self) -> Predictor:
        if self.predictor is None:
            raise ConfigError("a per-EP bundle ranks classes after the EPs done: use suggest_next_ep")
        return self.predictor

    def _attribute_scores(self, X: np.ndarray) -> np.ndarray:
        predictor = self._predictor()
        S = np.asarray(predictor.model.attribute_scores(X), dtype=float)
        if S.shape[0] != X.shape[0] or S.shape[-1] != len(self.attribute_names):
            raise ModelBundleError(f"{predictor.metadata.get('bundle', {}).get('path', 'model bundle')}: the model "
                                   f"returned attribute scores of shape {S.shape} for {X.shape[0]} grasps and "
                                   f"{len(self.attribute_names)} attributes")
        return S

    def model_input(self, grasp: Any) -> np.ndarray:
        """The model input of one grasp given as a feature array, shape (1, ...).

        Parameters
        ----------
        grasp : array-like of shape (n_sensors, n_features)
            Rows in the bundle's sensor order, columns in its feature order (metadata ``input``:
            ``sensors``, ``feature_names``), in the units of the training features. Bundles of
            other inputs (hand grasps, press videos) take files: :meth:`add_files`.
        """
        return grasp_model_input(self._predictor().input, grasp)

    def rank(self, grasp: Any) -> list[tuple[str, float]]:
        """The candidate classes ranked for one grasp alone (not added to the object's evidence).

        Parameters
        ----------
        grasp : array-like of shape (n_sensors, n_features)
            See :meth:`model_input`.

        Returns
        -------
        list of (class name, posterior) tuples, best first
            Posteriors over the candidate classes (sum to 1; calibrated when the bundle holds a
            calibrator); equal posteriors keep the class table's order.
        """
        p = self._posteriors(self._attribute_scores(self.model_input(grasp)))[0]
        order = np.argsort(-p, kind="stable")
        return [(self.class_names[i], float(p[i])) for i in order]

    def _class_scores(self, S: np.ndarray) -> np.ndarray:
        return self._predictor().class_scores(S, self._K)

    def _posteriors(self, S: np.ndarray) -> np.ndarray:
        return self._predictor().posteriors(self._class_scores(S))

    # ------------------------------------------------------------------ grasps as they arrive
    def reset(self) -> None:
        """Forget the grasps added so far (a new object)."""
        self._ids: list[str] = []
        self._sources: list[str] = []
        self._info: list[str] = []
        self._notes: list[str] = list(self.classes.attrs.get("notes", []))  # the class table's, e.g. left-out columns
        self._posterior_rows: list[np.ndarray] = []
        self._decisions: list[int] = []
        self._running: list[int] = []
        self._score_sum: np.ndarray | None = None
        self._final_posteriors: np.ndarray | None = None

    def add(self, grasp: Any, *, grasp_id: str | None = None, source: str = "array",
            info: str = "") -> Prediction:
        """Add one grasp of the current object and return the fused decision so far.

        Parameters
        ----------
        grasp : array-like of shape (n_sensors, n_features)
            See :meth:`model_input`.
        grasp_id : str, optional
            Default ``"grasp_<t>"``.
        source, info : str
            Shown in reports.

        Returns
        -------
        Prediction
            Every grasp added since :meth:`reset`: per-grasp posteriors and decisions, and the
            SC-MDAP or DF-MDAP decision (``decided``, ``final``, ``n_used``).
        """
        self._add_rows(self.model_input(grasp), [grasp_id or f"grasp_{len(self._ids) + 1}"], [source], [info])
        return self.prediction()

    def add_files(self, inputs: Sequence[str | Path]) -> Prediction:
        """Add the grasps of files (in this order), read as ``tzsl predict GRASP...`` reads them.

        Feature files (.csv / .npz), signal files, hand grasp files or folders, press videos:
        whatever the bundle's feature schema takes
        (:func:`~tzsl.inference.predict_inputs.read_inputs`).
        """
        grasps = read_inputs(self._predictor().input, inputs)
        self._notes += list(grasps.notes)
        self._add_rows(grasps.X, list(grasps.grasp_ids), list(grasps.sources), list(grasps.info))
        return self.prediction()

    def classify(self, inputs: Sequence[str | Path]) -> Prediction:
        """:meth:`reset`, then :meth:`add_files`: the result of ``tzsl predict`` on these files."""
        self.reset()
        return self.add_files(inputs)

    def _add_rows(self, X: np.ndarray, ids: list[str], sources: list[str], info: list[str]) -> None:
        """Add grasps one by one (so a batch of files and grasps added one at a time agree)."""
        for i in range(X.shape[0]):
            S = self._attribute_scores(X[i : i + 1])
            scores = self._class_scores(S)
            self._posterior_rows.append(self._predictor().posteriors(scores)[0])
            self._decisions.append(int(scores[0].argmax()))
            self._score_sum = S[0].copy() if self._score_sum is None else self._score_sum + S[0]
            if self.mode == "df":  # the super grasp of the grasps so far (eqs. 11-12)
                run = self._class_scores(self._score_sum[None] / len(self._decisions))
                self._running.append(int(run[0].argmax()))
                self._final_posteriors = self._predictor().posteriors(run)[0]
            self._ids.append(ids[i])
            self._sources.append(sources[i])
            self._info.append(info[i])

    def prediction(self) -> Prediction:
        """The grasps added since :meth:`reset` and their fused decision.

        Raises
        ------
        ConfigError
            No grasp added yet.
        """
        if not self._decisions:
            raise ConfigError("no grasp added yet: add(grasp) or add_files(paths) first")
        decisions = np.asarray(self._decisions, dtype=int)
        n = decisions.size
        running = final_p = None
        if self.mode == "sc":
            d, used, ok = sc_mdap(decisions[None, :], self.k)
            final, n_used, decided = int(d[0]), int(used[0]), bool(ok[0])
        else:
            running, final_p = np.asarray(self._running, dtype=int), self._final_posteriors
            final, n_used, decided = int(running[-1]), n, True
        return Prediction(classes=list(self.class_names), grasp_ids=list(self._ids), sources=list(self._sources),
                          info=list(self._info), grasp_posteriors=np.stack(self._posterior_rows), decisions=decisions,
                          mode=self.mode, k=self.k, decided=decided, n_used=n_used, final=final,
                          final_posteriors=final_p, running=running, notes=list(self._notes))

    # ------------------------------------------------------------------ active touch
    def suggest_next_ep(self, done: Mapping[str, Any], *, trial: str = "object", threshold: float | None = None,
                        max_eps: int | None = None, max_seconds: float | None = None) -> dict:
        """Ranking, decision and the next EP after the EPs done so far (per-EP bundles).

        Parameters
        ----------
        done : mapping of str -> array-like of shape (n_sensors, n_ep_features)
            Each EP done on the object (e.g. ``"squeeze"``) -> its features: rows in the bundle's
            sensor order, columns the EP's own feature columns in the bundle's order (feature
            names ``"<ep>:<feature>"``), units of training.
        trial : str
            Name of the object in the report.
        threshold, max_eps, max_seconds
            Stopping rule and budgets (``tzsl predict --threshold --max-eps --max-seconds``).

        Returns
        -------
        dict (JSON-serialisable)
            As ``tzsl predict --eps-done ... --json`` (:func:`~tzsl.inference.predict_active.active_report`):
            ``ranking``, ``decided``, ``decision``, ``next_ep``, ``expected_gain_bits``, ``candidates``, ...
        """
        if self.per_ep is None:
            raise ConfigError(f"suggest_next_ep needs a per-EP bundle (tzsl train-attributes --per-ep); "
                              f"this bundle is of kind {self.kind!r}")
        from tzsl.inference.predict_active import active_report_from_features  # noqa: PLC0415

        model, metadata = self.per_ep
        arrays = {str(ep): np.asarray(x, dtype=np.float64) for ep, x in done.items()}
        return active_report_from_features(model, metadata, self.classes, arrays, trial, threshold=threshold,
                                           max_eps=max_eps, max_seconds=max_seconds)

    def suggest_next_ep_from_file(self, features_file: str | Path, eps_done: Sequence[str], *,
                                  threshold: float | None = None, max_eps: int | None = None,
                                  max_seconds: float | None = None) -> dict:
        """:meth:`suggest_next_ep` with the done EPs' features read from one trial's feature file
        (``tzsl predict --eps-done EP,EP FILE``)."""
        if self.per_ep is None:
            raise ConfigError(f"--eps-done needs a per-EP bundle (tzsl train-attributes --per-ep); this bundle is "
                              f"of kind {self.kind!r}")
        from tzsl.inference.predict_active import active_report  # noqa: PLC0415

        model, metadata = self.per_ep
        return active_report(model, metadata, self.classes, features_file, list(eps_done), threshold=threshold,
                             max_eps=max_eps, max_seconds=max_seconds)


def predict_grasps(
    predictor: Predictor, classes: pd.DataFrame, inputs: Sequence[str | Path], *, mode: str = DEFAULT_FUSION,
    k: int = DEFAULT_K,
) -> Prediction:
    """Classify the grasps in ``inputs`` among ``classes`` and fuse them (SC-MDAP or DF-MDAP).

    The same as ``Recogniser(classes, predictor=predictor, mode=mode, k=k).classify(inputs)``.

    Parameters
    ----------
    predictor : Predictor
        From :func:`~tzsl.inference.zero_shot_bundles.load_predictor`.
    classes : DataFrame of shape (c, m)
        From :func:`~tzsl.inference.predict.read_class_table` (columns in the model's attribute order).
    inputs : sequence of paths
        In arrival order, read by the predictor's feature schema.
    mode : {"sc", "df"}
    k : int
        Equal classifications SC-MDAP needs.
    """
    return Recogniser(classes, predictor=predictor, mode=mode, k=k).classify(inputs)
