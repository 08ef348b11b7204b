"""The methods tzsl ships, one registration call each (see :mod:`tzsl.models._registry`)."""

from __future__ import annotations

from tzsl.models._registry import (
    DAP_METHOD,
    DAP_PAPER,
    ESZSL_PAPER,
    FABRIC_PAPER,
    register_alias,
    register_method,
)
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
    DAP_METHOD, family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule,
    defaults={"prior": "uni"}, input_ndim=3,
    description="per-(attribute, sensor) attribute detectors (detector: the paper's RBF-SVMs, linear or logistic "
                "ones, or chosen on the training objects), MAXDAP or AVGDAP over sensors (fusion, eqs. 5-6), uniform "
                "prior by default (balanced Platt posteriors: a train prior would correct twice)",
)
#: Older names of DAP configurations, still accepted (experiment files, --method, build_method): each fixes
#: what it was registered with; its name is the row label of that configuration (dap_label).
DAP_ALIASES: dict[str, dict[str, str]] = {
    "dap-avg": {"fusion": "avg", "prior": "uni"},
    "dap-max": {"fusion": "max", "prior": "uni"},
    "dap-avg-logistic": {"detector": "logistic", "fusion": "avg", "prior": "uni"},
    "dap-avg-linear-svm": {"detector": "linear-svm", "fusion": "avg", "prior": "uni"},
    "dap-avg-robust-logistic": {"detector": "robust-logistic", "fusion": "avg", "prior": "uni"},
    "dap-avg-logistic-c1": {"detector": "logistic-c1", "fusion": "avg", "prior": "uni"},
}
for _alias, _fixed in DAP_ALIASES.items():
    register_alias(_alias, DAP_METHOD, preset=_fixed)
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
