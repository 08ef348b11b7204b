"""Fabric groups, attribute matrices, depth images, zero-shot split, user GelSight video layout."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import (
    FABRIC_ATTRIBUTE_SETS,
    fabric_zsl_split,
    load_fabric,
    load_gelsight_fabric_videos,
    read_depth_images,
    read_fabric_groups,
)
from tzsl.datasets._fabric import _load_matrix, duplicate_rows
from tzsl.exceptions import ConfigError, DataFileError, DataMissingError, SplitError

SHARE = "share one attribute vector"


# -- real data ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fabric(data_dir):
    with pytest.warns(UserWarning, match=r"'a8': groups 3, 4, 5 " + SHARE):
        return load_fabric(data_dir)


@pytest.mark.realdata
def test_fabric_table_and_groups(fabric):
    f = fabric.fabrics
    assert list(f.columns) == ["fabric_id", "fabric_name", "group"]
    assert len(f) == 119 and f["fabric_id"].tolist() == list(range(1, 120))
    assert f["fabric_name"].iloc[6] == "F0007"
    assert f.groupby("group").size().tolist() == [8, 18, 25, 20, 9, 6, 20, 13]


@pytest.mark.realdata
def test_a8_matrix_and_its_duplicate_groups(fabric):
    a = fabric.attributes
    assert a.shape == (8, 8) and a.index.name == "group"
    assert list(a.columns) == [f"attr_{j}" for j in range(8)]
    assert set(np.unique(a.to_numpy())) == {0, 1}
    assert fabric.duplicate_groups == [(3, 4, 5)]
    np.testing.assert_array_equal(a.loc[3], a.loc[5])
    # columns 0 and 1 are complementary in every group (a Thin/Thick-like pair)
    np.testing.assert_array_equal(a["attr_0"] + a["attr_1"], np.ones(8))


@pytest.mark.realdata
def test_no_a8_column_is_zero_on_all_training_groups(fabric):
    """The paper says every training class has Thick = 0; no column of a8 fits that, which
    is one reason the column names cannot be assigned (module docstring)."""
    train = list(fabric_zsl_split(1).train_groups)
    assert (fabric.attributes.loc[train].sum(axis=0) > 0).all()


@pytest.mark.realdata
@pytest.mark.parametrize("name, dups", [("a4", [(2, 7), (3, 4, 5)]), ("a12", []),
                                        ("three_value_a8", []), ("three_value_a8v2", [])])
def test_alternative_matrices(data_dir, name, dups, recwarn):
    data = load_fabric(data_dir, name, images=False)
    assert data.attributes.shape == (8, FABRIC_ATTRIBUTE_SETS[name][1])
    assert data.duplicate_groups == dups
    assert len(recwarn) == (1 if dups else 0)
    assert data.images.empty
    for config in (1, 2):  # every shipped matrix separates the test groups of both configs
        fabric_zsl_split(config, data.attributes)


@pytest.mark.realdata
def test_image_table_and_lazy_reader(fabric):
    im = fabric.images
    assert len(im) == 1300 and im["image_id"].tolist() == list(range(1300))
    assert set(im["fabric_id"]) == set(range(1, 120))
    assert im.groupby("fabric_id").size().between(8, 16).all()
    # capture_index follows the timestamp within each fabric
    for _, g in im.groupby("fabric_id"):
        assert g["capture_index"].tolist() == list(range(len(g)))
        assert g["stamp"].is_monotonic_increasing
    f43 = im[im["fabric_id"] == 43]
    assert f43["stamp"].iloc[-1] == "230941" and f43["capture_index"].iloc[-1] == 11
    groups = fabric.fabrics.set_index("fabric_id")["group"]
    np.testing.assert_array_equal(fabric.image_labels(), groups.loc[im["fabric_id"]].to_numpy())
    x = fabric.read_images([0, 5, 1299])
    assert x.shape == (3, 224, 224) and x.dtype == np.uint16 and x.max() > 700
    xf = fabric.read_images(im["fabric_id"].to_numpy() == 2, dtype=np.float32)
    assert xf.dtype == np.float32 and xf.shape[0] == (im["fabric_id"] == 2).sum()


@pytest.mark.realdata
def test_missing_depth_images_are_reported(data_dir, tmp_path):
    """A data home whose depth folder lacks 3 images (built from symlinks, nothing copied)."""
    home = tmp_path / "home"
    (home / "fabric" / "depth224").mkdir(parents=True)
    src = data_dir / "fabric"
    for p in src.iterdir():
        if p.is_file():
            os.symlink(p, home / "fabric" / p.name)
    pngs = sorted((src / "depth224").iterdir())
    for p in pngs[3:]:
        os.symlink(p, home / "fabric" / "depth224" / p.name)
    with pytest.warns(UserWarning, match=SHARE), pytest.raises(
        DataMissingError, match=rf"3 of 1300 fabric depth images are missing \(first: fabric/depth224/{pngs[0].name}"
    ):
        load_fabric(home)


def test_unknown_attribute_set():
    with pytest.raises(ConfigError, match="attributes must be one of"):
        load_fabric(attributes="a9")


# -- validation helpers (synthetic files) ----------------------------------------------------
def test_matrix_validation(tmp_path):
    p = tmp_path / "m.npy"
    np.save(p, np.ones((7, 8), dtype=int))
    with pytest.raises(DataFileError, match=r"shape \(7, 8\); expected \(8, 8\)"):
        _load_matrix(p, 8)
    np.save(p, np.full((8, 8), 2))
    with pytest.raises(DataFileError, match="must be binary"):
        _load_matrix(p, 8)
    p.write_bytes(b"garbage")
    with pytest.raises(DataFileError, match="cannot read .npy"):
        _load_matrix(p, 8)


def test_duplicate_rows():
    m = np.array([[1, 0], [0, 1], [1, 0], [1, 1], [0, 1], [1, 0]])
    assert duplicate_rows(m) == [(1, 4), (0, 2, 5)] or duplicate_rows(m) == [(0, 2, 5), (1, 4)]
    assert duplicate_rows(np.eye(3)) == []


def test_group_table_validation(tmp_path):
    p = tmp_path / "fabric_groups.csv"
    p.write_text("fabric_id,fabric_name,group\n1,F0001,2\n2,F0002,0\n")
    t = read_fabric_groups(p)
    assert t["group"].tolist() == [2, 0] and t["fabric_id"].dtype == np.int64
    p.write_text("fabric_id,fabric_name\n1,F0001\n")
    with pytest.raises(DataFileError, match=r"missing column\(s\) \['group'\]"):
        read_fabric_groups(p)
    p.write_text("fabric_id,fabric_name,group\n1,F0001,2\n1,F0002,0\n")
    with pytest.raises(DataFileError, match=r"duplicate fabric_id values \[1\]"):
        read_fabric_groups(p)
    p.write_text("fabric_id,fabric_name,group\n1,F0001,9\n")
    with pytest.raises(DataFileError, match=r"group values \[9\] outside 0..7"):
        read_fabric_groups(p)
    p.write_text("fabric_id,fabric_name,group\nx,F0001,1\n")
    with pytest.raises(DataFileError, match="'fabric_id' must hold integers"):
        read_fabric_groups(p)
    with pytest.raises(DataMissingError):
        read_fabric_groups(tmp_path / "none.csv")


def test_depth_image_validation(tmp_path):
    import imageio.v3 as iio

    good = tmp_path / "good.png"
    iio.imwrite(good, np.full((224, 224), 1000, np.uint16))
    small = tmp_path / "small.png"
    iio.imwrite(small, np.zeros((100, 224), np.uint16))
    eight = tmp_path / "eight.png"
    iio.imwrite(eight, np.zeros((224, 224), np.uint8))
    np.testing.assert_array_equal(read_depth_images([good]), np.full((1, 224, 224), 1000))
    with pytest.raises(DataFileError, match=r"small\.png.*shape \(100, 224\)"):
        read_depth_images([good, small])
    with pytest.raises(DataFileError, match=r"eight\.png.*expected 16-bit"):
        read_depth_images([eight])
    with pytest.raises(DataMissingError, match="gone.png"):
        read_depth_images([tmp_path / "gone.png"])


# -- zero-shot split -------------------------------------------------------------------------
def test_split_configs():
    s1 = fabric_zsl_split(1)
    assert s1.train_groups == (1, 2, 3, 4, 6) and s1.test_groups == (0, 5, 7)
    s2 = fabric_zsl_split(2)
    assert s2.train_groups == (1, 2, 3, 5, 6) and s2.test_groups == (0, 4, 7)
    groups = np.array([0, 1, 5, 7, 4, 4])
    np.testing.assert_array_equal(s1.is_test(groups), [1, 0, 1, 1, 0, 0])
    np.testing.assert_array_equal(s1.is_train(groups), [0, 1, 0, 0, 1, 1])
    with pytest.raises(ConfigError, match="must be one of"):
        fabric_zsl_split(3)


def test_split_rejects_coinciding_test_vectors():
    m = np.eye(8, dtype=int)
    fabric_zsl_split(1, m)
    m[7] = m[0]  # test groups 0 and 7 coincide
    with pytest.raises(SplitError, match=r"config 1: test groups \[0, 7\] share one attribute vector"):
        fabric_zsl_split(1, m)
    m = np.eye(8, dtype=int)
    m[4] = m[0]  # only a test group of config 2
    fabric_zsl_split(1, m)
    with pytest.raises(SplitError, match=r"test groups \[0, 4\]"):
        fabric_zsl_split(2, pd.DataFrame(m))
    with pytest.raises(SplitError, match="shape"):
        fabric_zsl_split(1, np.eye(5))


# -- user-supplied GelSight videos -----------------------------------------------------------
def _write_avi(path, n=6):
    import imageio.v3 as iio

    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, np.zeros((n, 32, 32, 3), np.uint8), plugin="FFMPEG", fps=30, codec="mjpeg")


@pytest.fixture
def video_root(tmp_path):
    root = tmp_path / "gelsight"
    root.mkdir()
    (root / "fabric_groups.csv").write_text("fabric_id,fabric_name,group\n1,F0001,2\n2,F0002,0\n10,F0010,7\n")
    for cond, fab, press in [("Flat", "F0001", "1"), ("Flat", "F0001", "2"), ("Flat", "F0001", "10"),
                             ("Flat", "F0010", "1"), ("Fold", "F0002", "a")]:
        _write_avi(root / cond / fab / f"{press}.avi")
    (root / "Flat" / "F0001" / "notes.txt").write_text("ignored")
    return root


def test_user_video_layout(video_root):
    from tzsl.datasets import read_video

    t = load_gelsight_fabric_videos(video_root)
    assert list(t.columns) == ["condition", "fabric_id", "fabric_name", "group", "press", "press_index", "path"]
    assert t["condition"].tolist() == ["Flat"] * 4 + ["Fold"]
    assert t["press"].tolist() == ["1", "2", "10", "1", "a"]  # numeric order, not "1, 10, 2"
    assert t["press_index"].tolist() == [0, 1, 2, 0, 0]
    assert t["group"].tolist() == [2, 2, 2, 7, 0]
    assert read_video(t["path"].iloc[0]).shape == (6, 32, 32, 3)
    assert load_gelsight_fabric_videos(video_root, ["Fold"])["fabric_name"].tolist() == ["F0002"]


def test_user_video_layout_errors(video_root, tmp_path):
    with pytest.raises(DataMissingError, match="Rand.*condition folder not found"):
        load_gelsight_fabric_videos(video_root, ["Flat", "Rand"])
    _write_avi(video_root / "Rand" / "F0099" / "1.avi")
    with pytest.raises(DataFileError, match="'F0099' is not a fabric_name"):
        load_gelsight_fabric_videos(video_root)
    (video_root / "Rand" / "F0099" / "1.avi").unlink()
    (video_root / "Rand" / "F0099").rmdir()
    with pytest.raises(DataMissingError, match="Rand.*holds no"):
        load_gelsight_fabric_videos(video_root)
    (video_root / "fabric_groups.csv").unlink()
    with pytest.raises(DataMissingError, match="fabric group table not found"):
        load_gelsight_fabric_videos(video_root)
    with pytest.raises(DataMissingError, match="not found"):
        load_gelsight_fabric_videos(tmp_path / "nowhere")
