"""The built-in datasets whose features tzsl computes: ``fabric-depth`` (real depth images) and
``hand-simulated`` (SIMULATED Shadow-hand grasps; they exercise the contract, they measure nothing)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import dataset_names, get_dataset, load_fabric, load_hand_table4, simulate_grasps
from tzsl.features import dataset_features, depth_image_descriptors, grasp_features


def test_both_are_registered_and_listed():
    assert {"fabric-depth", "hand-simulated"} <= set(dataset_names())
    assert get_dataset("hand-simulated").simulated and not get_dataset("fabric-depth").simulated
    listed = {d["name"]: d for d in json.loads(CliRunner().invoke(cli, ["datasets", "--json"]).output)}
    assert listed["fabric-depth"]["content"] == "depth-images"
    assert listed["hand-simulated"]["content"] == "simulated-grasps"
    assert "SIMULATED" in listed["hand-simulated"]["description"]


def test_hand_simulated_is_the_hand_studys_packed_features_of_its_seed():
    features = dataset_features("hand-simulated")
    table = load_hand_table4()
    sim = simulate_grasps(table.K, material_attributes=table.material_attributes,
                          random_state=get_dataset("hand-simulated").seed)
    packed = grasp_features(sim.grasps).to_array()
    assert features.X.shape == (packed.shape[0], 1, packed.shape[1]) and features.sensors == ("hand",)
    np.testing.assert_array_equal(features.X[:, 0, :], packed)
    assert len(features.feature_names) == packed.shape[1]
    assert features.dataset == "hand-simulated" and features.info["simulated"]
    assert list(features.trials["object_name"]) == [g.object_name for g in sim.grasps]
    assert (features.trials["class"] == features.trials["object_name"]).all()
    assert features.n_objects == len(table.K)
    # attribute rows: Table 4's, minus the attributes of fewer than 3 objects (the DAP filter)
    kept = [a for a in table.K.columns if table.K[a].sum() >= 3]
    assert list(features.attributes.columns) == kept
    np.testing.assert_array_equal(features.attributes.to_numpy(), table.K.loc[features.attributes.index, kept])


@pytest.mark.slow
def test_fabric_depth_is_one_trial_per_image_and_one_object_per_group(data_dir):
    """A split holds out whole fabric groups (the fabric paper's unseen classes), never a fabric of a training group."""
    features = dataset_features("fabric-depth", data_dir=data_dir)
    fabric = load_fabric(data_dir)
    images = fabric.images
    assert features.X.shape == (len(images), 1, 99) and features.sensors == ("depth",)
    np.testing.assert_allclose(features.X[:, 0, :], depth_image_descriptors(fabric))
    assert list(features.trials["object_name"]) == [f"group-{g}" for g in images["group"]]
    assert (features.trials["class"] == features.trials["object_name"]).all()
    assert list(features.trials["fabric"]) == list(images["fabric_name"])
    assert features.n_objects == 8 == images["group"].nunique()
    # every group's attribute row is its row of the a8 matrix, on the attributes kept in >= 3 groups
    kept = list(features.attributes.columns)
    groups = [int(name.split("-")[1]) for name in features.attributes.index]
    np.testing.assert_array_equal(features.attributes.to_numpy(), fabric.attributes.loc[groups, kept].to_numpy())
    assert (features.attributes.sum() >= 3).all() and features.attributes.shape[1] >= 3
    assert set(features.info["data_files"]) == {str(p) for p in images["path"]}
