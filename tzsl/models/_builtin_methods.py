"""The methods tzsl ships, one registration call each (see :mod:`tzsl.models._registry`)."""

from __future__ import annotations

from tzsl.models._registry import DAP_PAPER, ESZSL_PAPER, FABRIC_PAPER, register_method
from tzsl.models.detectors import IAP, AttributeClassifierBank, MultiLabelAttributeClassifier
from tzsl.models.embedding import ALE, ESZSLCV, SAECV, SJE, DeepAttributeEmbedding, DeViSE, EmbeddingZSL
from tzsl.models.ensemble import ScoreEnsembleZSL
from tzsl.models.hand import HandDAPClassifier
from tzsl.models.rules import CompatibilityRule, DAPRule, NearestAttributeRule

IAP_PAPER = (
    "Lampert, Nickisch, Harmeling (2009): Learning to detect unseen object classes by between-class attribute "
    "transfer. CVPR"
)
SAE_PAPER = "Kodirov, Xiang, Gong (2017): Semantic autoencoder for zero-shot learning. CVPR"
ALE_PAPER = "Akata, Perronnin, Harchaoui, Schmid (2016): Label-embedding for image classification. TPAMI 38(7)"
SJE_PAPER = (
    "Akata, Reed, Walter, Lee, Schiele (2015): Evaluation of output embeddings for fine-grained image classification. "
    "CVPR"
)
ENSEMBLE_PAPER = (
    "tzsl (issue 14): equal-weight mean of trial-wise z-scored class scores of DAP (Abderrahmane et al. 2018), ESZSL "
    "(Romera-Paredes, Torr 2015) and SAE (Kodirov et al. 2017)"
)
DEVISE_PAPER = (
    "Frome, Corrado, Shlens, Bengio, Dean, Ranzato, Mikolov (2013): DeViSE: a deep visual-semantic embedding model. "
    "NIPS"
)

_PROB = "attribute-classifier"
register_method(
    "dap-avg", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule,
    preset={"fusion": "avg", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) RBF-SVMs, AVGDAP over sensors (eq. 6), uniform prior (balanced Platt "
                "posteriors: a train prior would correct twice)",
)
register_method(
    "dap-max", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule,
    preset={"fusion": "max", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) RBF-SVMs, MAXDAP over sensors (eq. 5), uniform prior",
)
register_method(
    "dap-avg-logistic", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule,
    preset={"detector": "logistic", "fusion": "avg", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) L2 logistic regressions (z-scored, C by object-grouped CV, Platt), AVGDAP, "
                "uniform prior",
)
register_method(
    "dap-avg-linear-svm", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule,
    preset={"detector": "linear-svm", "fusion": "avg", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) linear SVMs (z-scored, C by object-grouped CV, Platt), AVGDAP, uniform prior",
)
register_method(
    "dap-avg-robust-logistic", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank,
    decision_rule=DAPRule, preset={"detector": "robust-logistic", "fusion": "avg", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) logistic regressions trained group-robustly over training objects, AVGDAP, "
                "uniform prior",
)
register_method(
    "dap-avg-logistic-c1", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank,
    decision_rule=DAPRule, preset={"detector": "logistic-c1", "fusion": "avg", "prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) class-balanced L2 logistic regressions (z-scored, C = 1, nothing tuned), "
                "AVGDAP, uniform prior",
)
register_method(
    "multilabel-dap", family=_PROB, paper=DAP_PAPER, attribute_model=MultiLabelAttributeClassifier,
    decision_rule=DAPRule, preset={"prior": "uni"}, input_ndim=3,
    description="classifier chain of RBF-SVMs (joint attributes), DAP (§4.4)",
)
register_method(
    "ldap", family=_PROB, paper=DAP_PAPER, estimator=HandDAPClassifier, preset={"fusion": "ldap"}, input_kind="grasps",
    description="5-BioTac hand, one grasp, LDAP over touching fingers (eqs. 9-10)",
)
register_method(
    "hand-dap", family=_PROB, paper=DAP_PAPER, estimator=HandDAPClassifier, input_kind="grasps",
    description="5-BioTac hand, one grasp, MAXDAP/AVGDAP/LDAP (section 5)",
)
register_method(
    "eszsl", family="compatibility", paper=ESZSL_PAPER, attribute_model=ESZSLCV, decision_rule=CompatibilityRule,
    description="closed-form bilinear compatibility, ridges by class-grouped CV",
)
register_method(
    "embedding", family="embedding", paper=FABRIC_PAPER, attribute_model=EmbeddingZSL,
    decision_rule=NearestAttributeRule,
    description="features -> attribute vector with loss C + lambda R, nearest class",
)
register_method(
    "cnn-lstm", family="embedding", paper=FABRIC_PAPER, estimator=DeepAttributeEmbedding, input_kind="frames",
    description="CNN+LSTM over key-frame sequences, loss C + lambda R (needs torch)",
)
register_method(
    "iap", family=_PROB, paper=IAP_PAPER, attribute_model=IAP, decision_rule=DAPRule,
    description="classifier over training classes, attribute posteriors through their rows, then DAP",
)
register_method(
    "sae", family="embedding", paper=SAE_PAPER, attribute_model=SAECV, decision_rule=NearestAttributeRule,
    preset={"metric": "cosine"},
    description="semantic autoencoder (closed form), lambda by class-held-out CV, nearest class by cosine",
)
register_method(
    "ale", family="compatibility", paper=ALE_PAPER, attribute_model=ALE, decision_rule=CompatibilityRule,
    description="bilinear compatibility, weighted approximate ranking loss (SGD)",
)
register_method(
    "sje", family="compatibility", paper=SJE_PAPER, attribute_model=SJE, decision_rule=CompatibilityRule,
    description="bilinear compatibility, structured max-margin loss (SGD)",
)
register_method(
    "devise", family="compatibility", paper=DEVISE_PAPER, attribute_model=DeViSE, decision_rule=CompatibilityRule,
    description="bilinear compatibility, hinge rank loss over violating classes (SGD)",
)
register_method(
    "ensemble", family="ensemble", paper=ENSEMBLE_PAPER, estimator=ScoreEnsembleZSL, input_ndim=3, calibratable=True,
    description="DAP-AVG + ESZSL + SAE, class scores z-scored per trial and averaged (each member tuned on training "
                "objects only)",
)
