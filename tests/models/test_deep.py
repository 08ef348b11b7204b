"""DeepAttributeEmbedding (CNN + LSTM, F17): shapes, the F15 loss against the numpy model,
training, seeding, checkpoints, bundles, input errors."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import (
    check_no_attributes_set_in_init,
    check_parameters_default_constructible,
)

from tzsl.exceptions import ConfigError, DataFileError, ModelBundleError, TzslError
from tzsl.inference.deep_bundles import load_deep_bundle, save_deep_bundle
from tzsl.models import DeepAttributeEmbedding
from tzsl.models.embedding._embedding import _forward, _glorot_init, _layer_shapes, _loss_and_grad, loss_weights
from tzsl.models.embedding._eszsl import ZSLInputError

SKIP_REASON = "PyTorch is not installed (the optional deep extra: pip install 'tzsl[deep]')"

A4 = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [1, 1, 0, 1], [0, 0, 1, 1]], dtype=float)


@pytest.fixture
def torch():
    torch = pytest.importorskip("torch", reason=SKIP_REASON)
    before = torch.get_num_threads()
    torch.set_num_threads(1)  # tiny tensors: threads only add contention on a shared CI machine
    yield torch
    torch.set_num_threads(before)


def sequences(n_per_class=6, size=16, n_frames=5, seed=0, channels=None):
    """Synthetic frame sequences whose class shows in brightness and stripe frequency."""
    rng = np.random.default_rng(seed)
    y = np.repeat(np.arange(len(A4)), n_per_class)
    xx = np.arange(size)[None, None, None, :]
    t = np.arange(n_frames)[None, :, None, None]
    k = y[:, None, None, None]
    X = (100 + 30 * k * (t + 1) / n_frames + 40 * np.sin(xx * (k + 1) * 0.5)
         + rng.normal(0, 5, (len(y), n_frames, size, size)))
    X = np.clip(X, 0, 255).astype(np.uint8)
    if channels:
        X = np.repeat(X[..., None], channels, axis=-1)
    return X, y


def small(**kw):
    params = dict(backbone="small-cnn", finetune="all", hidden_size=8, epochs=3, batch_size=8, lr=1e-2,
                  random_state=0, n_threads=1)
    params.update(kw)
    return DeepAttributeEmbedding(**params)


def frozen(**kw):
    params = dict(backbone="efficientnet-lite0", image_size=32, hidden_size=16, epochs=8, batch_size=8, lr=1e-2,
                  random_state=0, n_threads=1)
    params.update(kw)
    return DeepAttributeEmbedding(**params)


# ------------------------------------------------------------------------- optional extra
def test_core_never_imports_torch():
    code = (
        "import sys, tzsl, tzsl.models, tzsl.studies.fabric.deep, tzsl.cli\n"
        "from tzsl.cli import cli\n"
        "from tzsl.models import DeepAttributeEmbedding; DeepAttributeEmbedding().get_params()\n"
        "assert 'torch' not in sys.modules, 'torch imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_torch_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch now raises ImportError
    X, y = sequences(n_per_class=2)
    with pytest.raises(TzslError, match=r"tzsl\[deep\]"):
        DeepAttributeEmbedding().fit(X, y, A4)


# ------------------------------------------------------------------------- loss
@pytest.mark.parametrize("lam", [0, 0.1, 1.0, 10.0, "inf"])
def test_torch_loss_equals_numpy_loss_and_gradient(torch, lam):
    """The torch F15 loss equals EmbeddingZSL's on the same f and attribute vectors, and autograd
    reproduces its analytic gradient."""
    from tzsl.models.embedding.deep._backbones import f15_loss

    rng = np.random.default_rng(1)
    n, d, k, m = 30, 7, 5, 6
    X = rng.normal(size=(n, d))
    L = rng.integers(0, 2, (k, m)).astype(float)
    y = rng.integers(0, k, n)
    shapes = _layer_shapes(d, m, None)
    theta = _glorot_init(shapes, np.random.RandomState(0)) + rng.normal(0, 0.3, sum(int(np.prod(s)) for s in shapes))
    w_c, w_r = loss_weights(lam)
    ref_loss, ref_grad = _loss_and_grad(theta, shapes, X, y, L, w_c, w_r, 0.0)

    W = torch.tensor(theta[: m * d].reshape(m, d), dtype=torch.float64, requires_grad=True)
    b = torch.tensor(theta[m * d :], dtype=torch.float64, requires_grad=True)
    F = torch.sigmoid(torch.as_tensor(X) @ W.T + b)
    np.testing.assert_allclose(F.detach().numpy(), _forward([theta[: m * d].reshape(m, d), theta[m * d :]], X)[0])
    loss = f15_loss(F, torch.as_tensor(L), torch.as_tensor(y), w_c, w_r)
    loss.backward()
    assert float(loss) == pytest.approx(ref_loss, rel=1e-12)
    np.testing.assert_allclose(np.concatenate([W.grad.numpy().ravel(), b.grad.numpy()]), ref_grad, rtol=1e-9,
                               atol=1e-12)


def test_loss_terms_by_hand(torch):
    from tzsl.models.embedding.deep._backbones import f15_loss

    F = torch.tensor([[0.2, 0.9], [0.6, 0.1]], dtype=torch.float64)
    L = torch.tensor([[0.0, 1.0], [1.0, 0.0]], dtype=torch.float64)
    y = torch.tensor([0, 1])
    d = ((F[:, None] - L[None]) ** 2).sum(-1).numpy()
    R = np.mean(d[[0, 1], [0, 1]])
    C = np.mean(-np.log(np.exp(-d[[0, 1], [0, 1]]) / np.exp(-d).sum(1)))
    assert float(f15_loss(F, L, y, 0.0, 1.0)) == pytest.approx(R)
    assert float(f15_loss(F, L, y, 1.0, 0.0)) == pytest.approx(C)
    assert float(f15_loss(F, L, y, 1.0, 10.0)) == pytest.approx(C + 10 * R)


# ------------------------------------------------------------------------- network
def test_forward_backward_shapes(torch):
    from tzsl.models.embedding.deep._backbones import DeepZSLNet, build_backbone, f15_loss

    torch.manual_seed(0)
    net = DeepZSLNet(build_backbone("small-cnn"), n_attributes=4, hidden_size=8, n_channels=1, image_size=None)
    seq = torch.rand(3, 5, 20, 20, 1) * 255
    F = net(seq)
    assert F.shape == (3, 4) and bool(((F > 0) & (F < 1)).all())
    assert net.frame_features(seq[:, 0]).shape == (3, 64)
    loss = f15_loss(F, torch.as_tensor(A4), torch.tensor([0, 1, 2]), 1.0, 0.1)
    loss.backward()
    for name, p in net.named_parameters():
        assert p.grad is not None and p.grad.shape == p.shape, name
        assert torch.isfinite(p.grad).all(), name
    assert net.lstm.weight_ih_l0.shape == (4 * 8, 64)
    assert net.head.weight.shape == (4, 8)


def test_pretrained_backbone_is_loaded_offline_and_checksummed(torch):
    import hashlib

    from tzsl.models.embedding.deep._backbones import build_backbone, bundled_weights_path

    path = bundled_weights_path("efficientnet-lite0")
    bb = build_backbone("efficientnet-lite0").eval()
    assert bb.weights_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert len(bb.stages) == 18 and bb.out_features == 1280
    ref = torch.load(path, weights_only=True)
    assert torch.equal(bb.stages[0].conv.weight, ref["_conv_stem.weight"])
    with torch.no_grad():
        f = bb(torch.rand(2, 3, 32, 32))
    assert f.shape == (2, 1280)
    with pytest.raises(ConfigError, match="weights_path"):
        build_backbone("vgg16")
    with pytest.raises(ConfigError, match="backbone"):
        build_backbone("resnet")


def test_foreign_weights_file_is_refused(torch, tmp_path):
    from tzsl.models.embedding.deep._backbones import build_backbone

    bad = tmp_path / "vgg.pth"
    torch.save({"features.0.weight": torch.zeros(2, 2)}, bad)
    with pytest.raises(DataFileError, match="VGG-16"):
        build_backbone("vgg16", bad)
    (tmp_path / "junk.pth").write_bytes(b"not a weights file")
    with pytest.raises(DataFileError, match="cannot read"):
        build_backbone("efficientnet-lite0", tmp_path / "junk.pth")
    with pytest.raises(DataFileError, match="not found"):
        build_backbone("vgg16", tmp_path / "missing.pth")


# ------------------------------------------------------------------------- estimator
def test_sklearn_parameter_conventions():
    est = DeepAttributeEmbedding(lam="inf", epochs=2)
    check_no_attributes_set_in_init("DeepAttributeEmbedding", est)
    check_parameters_default_constructible("DeepAttributeEmbedding", est)
    cloned = clone(est)
    assert cloned.get_params() == est.get_params()
    assert est.set_params(hidden_size=5) is est and est.hidden_size == 5


def test_frozen_fit_predict_and_cached_features(torch):
    X, y = sequences(channels=3)
    m = frozen().fit(X, y, A4)
    assert m.loss_curve_[-1] < 0.8 * m.loss_curve_[0]
    assert m.n_epochs_ == 8 and len(m.epoch_times_) == 8 and m.sequence_shape_ == (5, 16, 16, 3)
    # frozen backbone: nothing in it is trained, and the features were computed once
    assert not any(p.requires_grad for p in m.net_.parameters())
    F = m.transform(X)
    assert F.shape == (len(y), 4) and ((F > 0) & (F < 1)).all()
    scores = m.decision_function(X, A4)
    np.testing.assert_allclose(scores, -((F[:, None] - A4[None]) ** 2).sum(-1))
    pred = m.predict(X, A4)
    np.testing.assert_array_equal(pred, scores.argmax(1))
    np.testing.assert_allclose(m.predict_proba(X, A4).sum(1), 1.0)
    assert np.mean(pred == y) >= 0.75  # 4 classes: chance is 0.25
    # predicting among a subset of classes returns indices into that subset
    assert set(m.predict(X, A4[[3, 1]])) <= {0, 1}


def test_short_training_of_a_small_cnn_lowers_the_loss(torch):
    X, y = sequences(n_per_class=4, size=12)
    m = small(epochs=4).fit(X, y, A4)
    assert m.loss_curve_[-1] < m.loss_curve_[0]
    assert any(p.grad is not None for p in m.net_.backbone.parameters())  # the CNN itself was trained


def test_seeded_determinism(torch):
    X, y = sequences(n_per_class=3, size=12)
    a = small(epochs=2).fit(X, y, A4)
    b = small(epochs=2).fit(X, y, A4)
    c = small(epochs=2, random_state=1).fit(X, y, A4)
    assert a.loss_curve_ == b.loss_curve_
    np.testing.assert_array_equal(a.transform(X), b.transform(X))
    assert not np.array_equal(a.transform(X), c.transform(X))
    # fitting does not disturb the caller's global torch random stream
    torch.manual_seed(5)
    expected = torch.rand(3)
    torch.manual_seed(5)
    small(epochs=1).fit(X, y, A4)
    assert torch.equal(torch.rand(3), expected)


def test_checkpoint_resume_equals_an_uninterrupted_run(torch, tmp_path):
    X, y = sequences(n_per_class=3, size=12)
    full = small(epochs=4).fit(X, y, A4)
    ckpt = tmp_path / "ckpt"
    small(epochs=2, checkpoint_dir=ckpt).fit(X, y, A4)  # "killed" after 2 epochs
    assert (ckpt / "checkpoint.pt").is_file()
    resumed = small(epochs=4, checkpoint_dir=ckpt, resume=True).fit(X, y, A4)
    assert resumed.n_epochs_ == 4
    np.testing.assert_allclose(resumed.loss_curve_, full.loss_curve_, rtol=1e-6)
    np.testing.assert_allclose(resumed.transform(X), full.transform(X), rtol=1e-5, atol=1e-6)
    with pytest.raises(ConfigError, match="another configuration"):
        small(epochs=4, lam=1.0, checkpoint_dir=ckpt, resume=True).fit(X, y, A4)
    with pytest.raises(ConfigError, match="checkpoint_dir"):
        small(resume=True).fit(X, y, A4)


def test_frozen_features_are_cached_on_disk(torch, tmp_path):
    X, y = sequences(n_per_class=3)
    first = frozen(epochs=1, cache_dir=tmp_path).fit(X, y, A4)
    assert len(list(tmp_path.glob("features-*.pt"))) == 1 and not (tmp_path / "checkpoint.pt").exists()
    first.transform(X[:5])  # new frames: cached too
    assert len(list(tmp_path.glob("features-*.pt"))) == 2
    again = frozen(epochs=1, cache_dir=tmp_path, lam=1.0).fit(X, y, A4)
    assert again.feature_time_ < 0.5 * first.feature_time_
    np.testing.assert_array_equal(again.net_.feature_mean.numpy(), first.net_.feature_mean.numpy())


# ------------------------------------------------------------------------- bundles
def test_bundle_round_trip_and_tampering(torch, tmp_path, monkeypatch):
    import tzsl

    X, y = sequences(n_per_class=3, channels=3)
    labels = np.array(["wool", "silk", "denim", "felt"])[y]
    m = frozen(epochs=2).fit(X, labels, A4[np.argsort(["wool", "silk", "denim", "felt"])])
    path = save_deep_bundle(m, tmp_path / "m.tzsl-deep")
    with pytest.raises(ConfigError, match="exists"):
        save_deep_bundle(m, path)
    back = load_deep_bundle(path)
    np.testing.assert_array_equal(back.classes_, m.classes_)
    np.testing.assert_array_equal(back.class_attributes_, m.class_attributes_)
    np.testing.assert_allclose(back.transform(X), m.transform(X), rtol=1e-6)
    assert back.get_params()["lam"] == m.lam and back.sequence_shape_ == m.sequence_shape_
    # the frozen pretrained backbone is not stored, only its checksum
    assert path.stat().st_size < 2_000_000

    data = bytearray(path.read_bytes())
    data[-100] ^= 0xFF
    (tmp_path / "tampered.tzsl-deep").write_bytes(bytes(data))
    with pytest.raises(ModelBundleError, match="checksum"):
        load_deep_bundle(tmp_path / "tampered.tzsl-deep")

    monkeypatch.setattr(tzsl, "__version__", "0.9.0")
    save_deep_bundle(m, tmp_path / "other.tzsl-deep")
    monkeypatch.undo()
    with pytest.raises(ModelBundleError, match="tzsl 0.9.0"):
        load_deep_bundle(tmp_path / "other.tzsl-deep")

    other_weights = tmp_path / "other.pth"
    from tzsl.models.embedding.deep._backbones import bundled_weights_path

    state = torch.load(bundled_weights_path("efficientnet-lite0"), weights_only=True)
    state["_conv_stem.weight"] = state["_conv_stem.weight"] * 2
    torch.save(state, other_weights)
    with pytest.raises(ModelBundleError, match="differs"):
        load_deep_bundle(path, weights_path=other_weights)


def test_bundle_of_a_trained_cnn_stores_it(torch, tmp_path):
    from tzsl.inference.bundle import save_bundle

    X, y = sequences(n_per_class=2, size=12)
    m = small(epochs=1).fit(X, y, A4)
    back = load_deep_bundle(save_deep_bundle(m, tmp_path / "s.tzsl-deep"))
    np.testing.assert_allclose(back.transform(X), m.transform(X), rtol=1e-6)
    save_bundle(tmp_path / "wrong.tzsl", {"x": 1}, kind="hand-dap")
    with pytest.raises(ModelBundleError, match="expected a 'deep'"):
        load_deep_bundle(tmp_path / "wrong.tzsl")


# ------------------------------------------------------------------------- input errors
def test_bad_inputs_and_parameters(torch):
    X, y = sequences(n_per_class=2, size=12)
    with pytest.raises(ZSLInputError, match="shape"):
        small().fit(X[:, 0], y, A4)
    bad = X.astype(float)
    bad[2, 1, 3, 3] = np.nan
    with pytest.raises(ZSLInputError, match=r"sample\(s\) \[2\]"):
        small().fit(bad, y, A4)
    with pytest.raises(ZSLInputError, match="channels"):
        small().fit(np.repeat(X[..., None], 2, axis=-1), y, A4)
    with pytest.raises(ZSLInputError, match="one label per sequence"):
        small().fit(X, y[:-1], A4)
    with pytest.raises(ZSLInputError, match="rows"):
        small().fit(X, y, A4[:3])
    with pytest.raises(ZSLInputError, match="identical attribute rows"):
        small().fit(X, y, np.vstack([A4[:3], A4[:1]]))
    with pytest.raises(ConfigError, match="lam"):
        small(lam=-1).fit(X, y, A4)
    with pytest.raises(ConfigError, match="finetune"):
        small(finetune="some").fit(X, y, A4)
    with pytest.raises(ConfigError, match="backbone"):
        small(backbone="resnet").fit(X, y, A4)
    with pytest.raises(ConfigError, match="epochs"):
        small(epochs=0).fit(X, y, A4)
    m = small(epochs=1).fit(X, y, A4)
    with pytest.raises(ZSLInputError, match="fitted on"):
        m.predict(X[:, :4], A4)
    with pytest.raises(ZSLInputError, match="attributes"):
        m.predict(X, A4[:, :3])
    with pytest.raises(ZSLInputError, match="identical"):
        m.predict(X, np.vstack([A4, A4[:1]]))


# ------------------------------------------------------------------------- scikit-learn contract
@pytest.mark.parametrize(
    "params",
    [{"backbone": "resnet"}, {"lam": -1.0}, {"epochs": 0}, {"finetune": "some"}, {"optimizer": "rmsprop"},
     {"image_size": 4}, {"lr": 0.0}],
)
def test_bad_parameters_raise_invalid_parameter_error(params):
    """Held to the check_estimator contract by hand (it takes frame sequences, not a 2-D matrix)."""
    from sklearn.utils._param_validation import InvalidParameterError

    X, y = sequences(n_per_class=2)
    with pytest.raises(InvalidParameterError) as info:
        DeepAttributeEmbedding(**params).fit(X, y, A4)
    assert isinstance(info.value, TzslError)  # the CLI prints it in one line


def test_keyword_only_clone_and_params_round_trip():
    from sklearn.base import clone

    with pytest.raises(TypeError):
        DeepAttributeEmbedding("small-cnn")  # keyword-only
    model = small(lam="inf")
    params = model.get_params()
    assert clone(model).get_params() == params
    assert clone(model).set_params(lam=0.1).lam == 0.1 and model.lam == "inf"
    assert set(DeepAttributeEmbedding._parameter_constraints) == set(params)
