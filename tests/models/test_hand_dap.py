"""Single-grasp hand DAP: fusion equations 7-10 by hand, the estimator, and a simulated end-to-end run.

``HandDAPClassifier`` is not run through ``check_estimator``: its input is the packed grasp layout
(material block, 0/1 contact flags, shape block) and its ``fit`` needs the class-attribute table
``K`` covering ``y``, which the generic checks cannot provide. Its scikit-learn conventions
(parameters verbatim, ``clone``, ``get_params``/``set_params``, ``fit`` returns self, fitted
attributes, not-fitted error, seeded determinism) are tested here one by one. The per-attribute
classifiers inside are stock scikit-learn pipelines.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from tzsl.datasets._grasps import load_hand_table4
from tzsl.datasets._hand_simulator import simulate_grasps
from tzsl.exceptions import ConfigError, SplitError
from tzsl.features._grasp_features import grasp_features
from tzsl.models._dap import break_ties, dap_log_scores
from tzsl.models.hand._hand_dap import FUSIONS, HandDAPClassifier, NoContactError, fuse_grasp_posteriors

TABLE = load_hand_table4()

# One grasp, 3 BioTacs (the third not touching), 2 material and 2 shape attributes.
P_MAT = np.array([[[0.2, 0.9], [0.6, 0.3], [0.99, 0.99]]])
CONTACT = np.array([[True, True, False]])
P_SH = np.array([[0.3, 0.8]])


def test_maxdap_eq7():
    # material: max over touching BioTacs (0.2, 0.6) -> 0.6 and (0.9, 0.3) -> 0.9; shape unchanged
    np.testing.assert_allclose(fuse_grasp_posteriors(P_MAT, CONTACT, P_SH, "maxdap"), [[0.6, 0.9, 0.3, 0.8]])


def test_avgdap_eq8():
    # (0.2 + 0.6) / 2 = 0.4 and (0.9 + 0.3) / 2 = 0.6
    np.testing.assert_allclose(fuse_grasp_posteriors(P_MAT, CONTACT, P_SH, "avgdap"), [[0.4, 0.6, 0.3, 0.8]])


def test_ldap_eqs9_10():
    # material eq. 10: (max(.5,.2) + max(.5,.6)) / 2 = 0.55; (max(.5,.9) + max(.5,.3)) / 2 = 0.7
    # shape eq. 9: max(.5, .3) = 0.5; max(.5, .8) = 0.8
    np.testing.assert_allclose(fuse_grasp_posteriors(P_MAT, CONTACT, P_SH, "ldap"), [[0.55, 0.7, 0.5, 0.8]])


def test_ldap_one_finger_and_batch_dims():
    P = np.broadcast_to(P_MAT, (2, 3, 3, 2)).copy()
    C = np.zeros((2, 3, 3), dtype=bool)
    C[..., 1] = True  # only BioTac 1 touches: eq. 10 with B = 1 is max(0.5, p)
    out = fuse_grasp_posteriors(P, C, np.broadcast_to(P_SH, (2, 3, 2)), "ldap")
    assert out.shape == (2, 3, 4)
    np.testing.assert_allclose(out[1, 2], [0.6, 0.5, 0.5, 0.8])


def test_ldap_into_dap_by_hand():
    P = fuse_grasp_posteriors(P_MAT, CONTACT, P_SH, "ldap")  # [0.55, 0.7, 0.5, 0.8]
    K = np.array([[1, 0, 0, 1], [0, 1, 1, 1]], dtype=float)
    s = dap_log_scores(P, K, np.full(4, 0.5))
    # class 0: .55 * (1-.7) * (1-.5) * .8 ; class 1: (1-.55) * .7 * .5 * .8 ; prior terms equal
    expected_diff = np.log(0.55 * 0.3 * 0.5 * 0.8) - np.log(0.45 * 0.7 * 0.5 * 0.8)
    np.testing.assert_allclose(s[0, 0] - s[0, 1], expected_diff)
    assert s.argmax(axis=1).tolist() == [1]


def test_fusion_errors():
    with pytest.raises(NoContactError, match=r"\(0,\)"):
        fuse_grasp_posteriors(P_MAT, np.zeros_like(CONTACT), P_SH, "ldap")
    with pytest.raises(ConfigError, match="fusion"):
        fuse_grasp_posteriors(P_MAT, CONTACT, P_SH, "median")
    with pytest.raises(ValueError, match="shapes do not match"):
        fuse_grasp_posteriors(P_MAT, CONTACT[:, :2], P_SH, "ldap")


# ---------------------------------------------------------------------- estimator
@pytest.fixture(scope="module")
def hand_data():
    sim = simulate_grasps(TABLE.K, 30, random_state=0)
    fe = grasp_features(sim.grasps)
    train = np.isin(fe.objects, TABLE.train_objects)
    return fe.subset(train), fe.subset(~train)


@pytest.fixture(scope="module")
def fitted(hand_data):
    train, _ = hand_data
    clf = HandDAPClassifier(material_attributes=TABLE.material_attributes, random_state=0)
    return clf.fit(train.to_array(), train.objects, TABLE.K)


def test_end_to_end_above_chance(hand_data, fitted):
    """Simulated data, 6 training / 10 test objects of Table 4: every fusion is well above 1/10."""
    _, test = hand_data
    K_test = TABLE.K.loc[TABLE.test_objects]
    accs = {f: float(np.mean(fitted.predict(test.to_array(), K_test, fusion=f) == test.objects)) for f in FUSIONS}
    assert min(accs.values()) > 0.35, accs
    pred = fitted.predict(test.to_array(), K_test)
    assert set(pred) <= set(TABLE.test_objects)
    assert fitted.score(test.to_array(), test.objects, K_test) == pytest.approx(accs["ldap"])


def test_fitted_attributes_and_posteriors(hand_data, fitted):
    _, test = hand_data
    assert list(fitted.classes_) == TABLE.train_objects
    assert fitted.material_attributes_ == list(TABLE.material_attributes)
    assert fitted.shape_attributes_ == list(TABLE.shape_attributes)
    assert len(fitted.material_models_) == 5 and all(len(m) == 5 for m in fitted.material_models_)
    P_mat, contact, P_sh = fitted.attribute_posteriors(test.to_array())
    assert np.isnan(P_mat[~contact]).all() and not np.isnan(P_mat[contact]).any()
    assert ((P_sh >= 0) & (P_sh <= 1)).all()
    P = fitted.predict_attribute_proba(test.to_array(), "ldap")
    assert P.shape == (len(test), 11) and (P >= 0.5).all()
    # attribute classifiers generalise to the test objects' true attributes (balanced accuracy)
    A = TABLE.K.loc[test.objects].to_numpy()
    P_avg = fitted.predict_attribute_proba(test.to_array(), "avgdap")
    both = [m for m in range(11) if 0 < A[:, m].mean() < 1]  # no test object is made of cardboard
    assert len(both) == 10
    bal = [np.mean([np.mean((P_avg[A[:, m] == v, m] > 0.5) == v) for v in (0, 1)]) for m in both]
    assert np.mean(bal) > 0.7, bal
    # log scores over the training classes by default
    assert fitted.predict_log_scores(test.to_array()).shape == (len(test), 6)


def test_conventions_and_determinism(hand_data):
    train, test = hand_data
    clf = HandDAPClassifier(material_attributes=TABLE.material_attributes, fusion="avgdap", random_state=3)
    assert clf.get_params()["fusion"] == "avgdap"
    assert clone(clf).get_params() == clf.get_params()
    with pytest.raises(NotFittedError):
        clf.predict(test.to_array())
    assert clf.fit(train.to_array(), train.objects, TABLE.K) is clf
    again = clone(clf).fit(train.to_array(), train.objects, TABLE.K)
    np.testing.assert_array_equal(clf.predict_attribute_proba(test.to_array()),
                                  again.predict_attribute_proba(test.to_array()))
    pooled = clone(clf).set_params(per_finger=False).fit(train.to_array(), train.objects, TABLE.K)
    assert len(pooled.material_models_) == 1


def test_fit_and_predict_errors(hand_data, fitted):
    train, test = hand_data
    X, y = train.to_array(), train.objects
    with pytest.raises(ConfigError, match="no row in K"):
        HandDAPClassifier().fit(X, y, TABLE.K.drop(index="mug"))
    with pytest.raises(ConfigError, match="fusion"):
        HandDAPClassifier(fusion="best").fit(X, y, TABLE.K)
    with pytest.raises(ConfigError, match="not columns of K"):
        HandDAPClassifier(material_attributes=["wood"]).fit(X, y, TABLE.K)
    one_class = TABLE.K.assign(steel=0)  # an attribute with no positive training grasp: left out, said why
    relaxed = HandDAPClassifier(random_state=0).fit(X, y, one_class)
    assert "steel" not in relaxed.material_attributes_ and "steel" not in relaxed.K_.columns
    assert "0 positive" in relaxed.left_out_attributes_["steel"]
    with pytest.raises(SplitError, match="no attribute can be learned"):
        HandDAPClassifier().fit(X, y, TABLE.K.assign(**{a: 0 for a in TABLE.K.columns}))
    with pytest.raises(ConfigError, match="packed grasp-feature"):
        HandDAPClassifier().fit(X[:, :100], y, TABLE.K)
    with pytest.raises(ConfigError, match="lacks the attribute"):
        fitted.predict(test.to_array(), TABLE.K.drop(columns="round"))
    X_none = test.to_array()[:2].copy()
    X_none[:, 110:115] = 0.0  # no BioTac touching
    with pytest.raises(NoContactError):
        fitted.predict(X_none, TABLE.K.loc[TABLE.test_objects])


@pytest.mark.slow
def test_simulator_knobs_make_recognition_harder():
    """More sensor noise and object variation (difficulty) lower the LDAP accuracy."""

    def ldap_accuracy(noise: float, difficulty: float) -> float:
        fe = grasp_features(simulate_grasps(TABLE.K, 30, noise=noise, difficulty=difficulty, random_state=1).grasps)
        train = np.isin(fe.objects, TABLE.train_objects)
        a, b = fe.subset(train), fe.subset(~train)
        clf = HandDAPClassifier(material_attributes=TABLE.material_attributes, random_state=0)
        clf.fit(a.to_array(), a.objects, TABLE.K)
        return float(np.mean(clf.predict(b.to_array(), TABLE.K.loc[TABLE.test_objects]) == b.objects))

    easy, hard = ldap_accuracy(0.3, 0.0), ldap_accuracy(2.0, 1.5)
    assert easy > hard + 0.1, (easy, hard)


def test_hand_decision_is_the_dap_rule(hand_data, fitted):
    """The hand's decision (LDAP fusion inside its attribute layer, then DAP with p = 0.5) is DAPRule."""
    from tzsl.models import DAPRule, ParameterError

    train, test = hand_data
    X = test.to_array()
    K = fitted.K_.to_numpy(dtype=float)
    rule = DAPRule(prior="uni").fit(K)
    np.testing.assert_array_equal(
        fitted.predict_log_scores(X), rule.decision_function(fitted.predict_attribute_proba(X), K)
    )
    with pytest.raises(ParameterError, match="prior"):
        HandDAPClassifier(prior=1.5).fit(train.to_array(), train.objects, TABLE.K)
    with pytest.raises(TypeError):
        HandDAPClassifier(("glass",))  # keyword-only


def test_dap_rule_is_the_dap_arithmetic_with_the_models_prior(hand_data, fitted):
    """``dap_rule()`` (what the hand and active-touch studies score with) gives exactly the numbers and the
    seeded tie-breaks of DAP with ``p(a_m = 1) = prior`` on fused posteriors, single grasps and DF-MDAP means."""
    import copy

    from tzsl.models.multigrasp import df_mdap

    _, test = hand_data
    model = copy.deepcopy(fitted)
    model.prior = 0.3  # used only at decision time
    K = TABLE.K.loc[TABLE.test_objects, list(model.K_.columns)].to_numpy(dtype=float)
    P = model.predict_attribute_proba(test.to_array(), "ldap")
    super_grasps = df_mdap(P[: (len(P) // 3) * 3].reshape(-1, 3, P.shape[1]))
    prior = np.full(K.shape[1], 0.3)
    rule = model.dap_rule()
    for posteriors in (P, super_grasps):
        np.testing.assert_array_equal(rule.decision_function(posteriors, K), dap_log_scores(posteriors, K, prior))
        np.testing.assert_array_equal(rule.predict(posteriors, K, random_state=np.random.default_rng(7)),
                                      break_ties(dap_log_scores(posteriors, K, prior), np.random.default_rng(7)))
    assert not np.array_equal(rule.decision_function(P, K), fitted.dap_rule().decision_function(P, K))
