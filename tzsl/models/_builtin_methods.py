"""The methods tzsl ships, one registration line each (see :mod:`tzsl.models._registry`)."""

from __future__ import annotations

from tzsl.models._attribute_svm import AttributeClassifierBank
from tzsl.models._decision import CompatibilityRule, DAPRule, NearestAttributeRule
from tzsl.models._deep import DeepAttributeEmbedding
from tzsl.models._embedding import EmbeddingZSL
from tzsl.models._eszsl import ESZSLCV
from tzsl.models._hand_dap import HandDAPClassifier
from tzsl.models._multilabel import MultiLabelAttributeClassifier
from tzsl.models._registry import DAP_PAPER, ESZSL_PAPER, FABRIC_PAPER, register_method

_PROB = "attribute-classifier"
register_method("dap-avg", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule, preset={"fusion": "avg"}, description="per-(attribute, sensor) RBF-SVMs, AVGDAP over sensors (eq. 6)")
register_method("dap-max", family=_PROB, paper=DAP_PAPER, attribute_model=AttributeClassifierBank, decision_rule=DAPRule, preset={"fusion": "max"}, description="per-(attribute, sensor) RBF-SVMs, MAXDAP over sensors (eq. 5)")
register_method("multilabel-dap", family=_PROB, paper=DAP_PAPER, attribute_model=MultiLabelAttributeClassifier, decision_rule=DAPRule, description="classifier chain of RBF-SVMs (joint attributes), DAP (§4.4)")
register_method("ldap", family=_PROB, paper=DAP_PAPER, estimator=HandDAPClassifier, preset={"fusion": "ldap"}, description="5-BioTac hand, one grasp, LDAP over touching fingers (eqs. 9-10)")
register_method("hand-dap", family=_PROB, paper=DAP_PAPER, estimator=HandDAPClassifier, description="5-BioTac hand, one grasp, MAXDAP/AVGDAP/LDAP (section 5)")
register_method("eszsl", family="compatibility", paper=ESZSL_PAPER, attribute_model=ESZSLCV, decision_rule=CompatibilityRule, description="closed-form bilinear compatibility, ridges by class-grouped CV")
register_method("embedding", family="embedding", paper=FABRIC_PAPER, attribute_model=EmbeddingZSL, decision_rule=NearestAttributeRule, description="features -> attribute vector with loss C + lambda R, nearest class")
register_method("cnn-lstm", family="embedding", paper=FABRIC_PAPER, estimator=DeepAttributeEmbedding, description="CNN+LSTM over key-frame sequences, loss C + lambda R (needs torch)")
