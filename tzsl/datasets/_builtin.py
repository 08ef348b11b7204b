"""The dataset contract: a built-in dataset is its metadata plus a load method (as MOABB's ``BaseDataset``).

Every built-in dataset is a :class:`TactileDataset` registered by name; ``tzsl extract --dataset``,
``[dataset] builtin = ...`` in an experiment file, ``tzsl convert --dataset`` and the docs read the
names and descriptions from here. A dataset reads files (``load``: the data as published, no
features); :func:`tzsl.features.dataset_features` turns what it reads into a
:class:`~tzsl.datasets.FeatureSet`. A user's own data need no class: the plain-file format
(``tzsl formats``) and the lab readers (``tzsl convert --from``) cover it.

Adding a built-in dataset: a subclass with its metadata and ``load`` (and ``labels`` for raw
signals), then one :func:`register_dataset` line. A public dataset of the catalog
(``docs/user_guide/dataset_catalog.md``) is a :class:`CatalogDataset`: its files registered, a
``convert`` that writes it as a plain-file folder, and ``load`` reads that folder (converted once).
"""

from __future__ import annotations

import hashlib
import os
import warnings
from abc import ABC, abstractmethod
from importlib import resources
from pathlib import Path
from typing import ClassVar, Literal

import pandas as pd

from tzsl.datasets._biotac_slide import (
    ATTRIBUTE_TABLE,
    BIOTAC_SLIDE,
    BIOTAC_SLIDE_COMMIT,
    BIOTAC_SLIDE_DIR,
    convert_biotac_slide,
)
from tzsl.datasets._bts3 import ATTRIBUTE_TABLE as BTS3_TABLE
from tzsl.datasets._bts3 import BTS3, BTS3_COMMIT, convert_bts3
from tzsl.datasets._catalog import converted_folder
from tzsl.datasets._fabric import (
    FABRIC_ATTRIBUTE_SETS,
    FABRIC_DEPTH_DIR,
    FABRIC_GROUPS_CSV,
    FabricData,
    load_fabric,
)
from tzsl.datasets._grasps import load_hand_table4
from tzsl.datasets._hand_simulator import SimulatedGrasps, simulate_grasps
from tzsl.datasets._icub_grasp import ATTRIBUTE_TABLE as ICUB_GRASP_TABLE
from tzsl.datasets._icub_grasp import ICUB_GRASP, ICUB_GRASP_COMMIT, ICUB_GRASP_DIR, convert_icub_grasp
from tzsl.datasets._phac2_h5 import load_phac2_h5
from tzsl.datasets._phac2_hold_mat import HOLD_DIR, LABELS_CSV, load_phac2_hold_mat, load_phac2_labels
from tzsl.datasets._phac2_penn import PENN_STATIC_DIR, PennStaticData, load_phac2_penn
from tzsl.datasets._physiclear import convert_physiclear
from tzsl.datasets._physiclear_table import ATTRIBUTE_TABLE as PHYSICLEAR_TABLE
from tzsl.datasets._physiclear_table import PHYSICLEAR, PHYSICLEAR_COMMIT
from tzsl.datasets._physiclear_table import SPLIT_FILE as PHYSICLEAR_SPLITS
from tzsl.datasets._plain import PlainDataset, read_plain_dataset
from tzsl.datasets._registry import registered_files, registered_hash
from tzsl.datasets._types import PHAC2_EPS, RawTrial
from tzsl.exceptions import ConfigError

__all__ = ["CatalogDataset", "TactileDataset", "builtin_data_files", "dataset_names", "get_dataset", "register_dataset"]

PathLike = str | os.PathLike


class TactileDataset(ABC):
    """A built-in tactile dataset.

    Attributes
    ----------
    name : str
        Its name (``[dataset] builtin = name``).
    description : str
        One line: what it holds (trials, sensors, features).
    source : str
        Where it comes from (publication or release).
    content : {"static-features", "signals", "depth-images", "simulated-grasps", "plain"}
        ``load`` returns per-trial features as published (:class:`~tzsl.datasets.PennStaticData`),
        raw signals (a list of :class:`~tzsl.datasets.RawTrial`, with ``labels``), the fabric
        depth-image table (:class:`~tzsl.datasets.FabricData`; features: texture descriptors) or
        simulated Shadow-hand grasps (:class:`~tzsl.datasets.SimulatedGrasps`, with ``labels``;
        features: the packed grasp features), or a plain-file dataset folder
        (:class:`~tzsl.datasets.PlainDataset`, a :class:`CatalogDataset`; features as the plain format
        computes them).
    eps : tuple of str
        The exploratory procedures its trials hold.
    needs_path : bool
        ``load`` reads a file the user gives (``path``) instead of the data home.
    convertible : bool
        ``tzsl convert --dataset`` can write it as a plain-file folder.
    simulated : bool
        Its trials are drawn by tzsl's simulator, not recorded: every result on it says
        ``data = simulated``.
    registry_files : tuple of str
        The registered files ``load`` and ``labels`` read from the data home (paths, or folder
        prefixes ending in ``/``, of the dataset registry): what a study on it fetches first
        (:func:`builtin_data_files`).
    ships_splits : bool
        Its plain-file folder holds its publication's split (``splits.csv``), which a study's
        ``[splits] kinds = ["file"]`` reads when no ``file`` is given.
    """

    name: ClassVar[str]
    description: ClassVar[str]
    source: ClassVar[str]
    content: ClassVar[Literal["static-features", "signals", "depth-images", "simulated-grasps", "plain"]]
    eps: ClassVar[tuple[str, ...]]
    needs_path: ClassVar[bool] = False
    convertible: ClassVar[bool] = True
    simulated: ClassVar[bool] = False
    registry_files: ClassVar[tuple[str, ...]] = ()
    ships_splits: ClassVar[bool] = False

    @abstractmethod
    def load(self, data_dir: PathLike | None = None, path: PathLike | None = None
             ) -> PennStaticData | list[RawTrial] | FabricData | SimulatedGrasps | PlainDataset:
        """The data as published (files read from the data home, or ``path``)."""

    def labels(self, data_dir: PathLike | None = None) -> pd.DataFrame:
        """The object x attribute table of a ``signals`` dataset (objects as rows, 0/1)."""
        raise NotImplementedError(f"{self.name} publishes its labels with its features")

    def data_files(self, loaded: PennStaticData | list[RawTrial]) -> list[str]:
        """The files ``loaded`` was read from (recorded in every manifest)."""
        if isinstance(loaded, PennStaticData):
            return sorted(str(p) for p in loaded.sources)
        return sorted({str(t.source) for t in loaded})


class Phac2Penn(TactileDataset):
    name = "phac2-penn"
    description = "Penn's static features of all 600 PHAC-2 trials (60 objects x 10), 2 BioTacs x 4 EPs"
    source = "Chu et al. (2015), PHAC-2; Penn's per-trial static features"
    content = "static-features"
    eps = tuple(PHAC2_EPS)
    registry_files = (PENN_STATIC_DIR, LABELS_CSV)

    def load(self, data_dir=None, path=None) -> PennStaticData:
        return load_phac2_penn(data_dir)


class Phac2HoldMat(TactileDataset):
    name = "phac2-hold-mat"
    description = "the raw HOLD-phase signals of 6 PHAC-2 objects x 10 trials (MATLAB), 2 BioTacs"
    source = "Chu et al. (2015), PHAC-2 raw release (HOLD phase)"
    content = "signals"
    eps = ("hold",)
    registry_files = (HOLD_DIR, LABELS_CSV)

    def load(self, data_dir=None, path=None) -> list[RawTrial]:
        return load_phac2_hold_mat(data_dir)

    def labels(self, data_dir=None) -> pd.DataFrame:
        return load_phac2_labels(data_dir)


class Phac2H5(TactileDataset):
    name = "phac2-h5"
    description = "the official raw PHAC-2 HDF5 release at --path, 2 BioTacs x 4 EPs"
    source = "Chu et al. (2015), PHAC-2 HDF5 release (not redistributed; give its path)"
    content = "signals"
    eps = tuple(PHAC2_EPS)
    needs_path = True
    convertible = False
    registry_files = (LABELS_CSV,)  # the labels; the release itself is the user's file (path)

    def load(self, data_dir=None, path=None) -> list[RawTrial]:
        if path is None:
            raise ConfigError(f"--dataset {self.name} needs --path pointing at the PHAC-2 HDF5 release file")
        return load_phac2_h5(path)

    def labels(self, data_dir=None) -> pd.DataFrame:
        return load_phac2_labels(data_dir)


class FabricDepth(TactileDataset):
    """The fabric study's public depth images: one trial per image, one object (and class) per fabric group.

    A split holds out fabric groups, as the fabric paper does (:func:`tzsl.features.fabric_depth_feature_set`).
    The attribute rows are the group x attribute matrix that :func:`~tzsl.datasets.load_fabric` reads
    by default (a8: 8 attributes, the fabric paper's; groups 3, 4 and 5 share one row, so 6 distinct
    rows). a12, which the fabric study's ``[partitions]`` use, is a partition protocol's matrix, not
    the paper's.
    """

    name = "fabric-depth"
    description = ("the 1300 public depth images of 119 fabrics in 8 groups (the objects and classes; a8 group "
                   "attributes), one trial per image, texture-descriptor features")
    source = "the fabric paper (Fabric Recognition Using Zero-Shot Learning); its public depth images and groups"
    content = "depth-images"
    eps = ("press",)
    convertible = False
    registry_files = (FABRIC_GROUPS_CSV, f"fabric/{FABRIC_ATTRIBUTE_SETS['a8'][0]}", FABRIC_DEPTH_DIR)

    def load(self, data_dir=None, path=None) -> FabricData:
        with warnings.catch_warnings():  # groups sharing a row are expected (the dataset card lists them)
            warnings.filterwarnings("ignore", message="fabric attribute matrix", category=UserWarning)
            return load_fabric(data_dir, images=True)

    def data_files(self, loaded: FabricData) -> list[str]:  # type: ignore[override]  # given only its own load()
        return sorted(str(p) for p in loaded.images["path"])


class HandSimulated(TactileDataset):
    """Shadow-hand grasps drawn by tzsl's simulator from the DAP paper's Table 4 (no robot data).

    The simulator's default settings (:func:`~tzsl.datasets.simulate_grasps`) and :attr:`seed`;
    one object per Table 4 row (16), classes = objects.
    """

    name = "hand-simulated"
    description = "SIMULATED Shadow-hand grasps (5 BioTacs, 19 joints) of Table 4's 16 objects x 11 attributes"
    source = "tzsl's grasp simulator over the DAP paper's Table 4 (the paper's recordings are not public)"
    content = "simulated-grasps"
    eps = ("grasp",)
    convertible = False
    simulated = True
    #: The simulator's seed (the hand study's first ``[splits] seeds`` value).
    seed: ClassVar[int] = 0

    def load(self, data_dir=None, path=None) -> SimulatedGrasps:
        table = load_hand_table4()
        return simulate_grasps(table.K, material_attributes=table.material_attributes, random_state=self.seed)

    def labels(self, data_dir=None) -> pd.DataFrame:
        return load_hand_table4().K

    def data_files(self, loaded: SimulatedGrasps) -> list[str]:  # type: ignore[override]  # given only its own load()
        return []


class CatalogDataset(TactileDataset):
    """A public tactile dataset of the catalog: fetched as published, written once as a plain-file folder.

    A subclass names its registered files (:attr:`registry_files`) and implements :meth:`convert`;
    :meth:`load` converts into the cache folder the first time (``<cache folder>/catalog/<name>-<key>``,
    the key a digest of the registered hashes of the files, :attr:`version` and
    :meth:`conversion_inputs`) and reads that folder.
    """

    content = "plain"
    #: The loader's version: raise it when :meth:`convert` writes something else from the same files.
    version: ClassVar[str] = "1"

    @abstractmethod
    def convert(self, out: PathLike, data_dir: PathLike | None = None, *, force: bool = False,
                signal_format: str = "npz") -> Path:
        """Write the dataset as a plain-file folder ``out`` from the registered files in the data home."""

    #: Files of the package :meth:`convert` reads besides the registered ones (its class table, a split file).
    package_files: ClassVar[tuple[str, ...]] = ()

    def conversion_inputs(self) -> list[str]:
        """What :meth:`convert` depends on besides the registered files: the sha256 of each of :attr:`package_files`."""
        files = resources.files("tzsl.datasets")
        return [hashlib.sha256(files.joinpath(name).read_bytes()).hexdigest() for name in self.package_files]

    def load(self, data_dir: PathLike | None = None, path: PathLike | None = None) -> PlainDataset:
        parts = [self.name, self.version, *self.conversion_inputs(),
                 *(f"{r} {registered_hash(r)}" for r in builtin_data_files(self.name))]
        return read_plain_dataset(converted_folder(self.name, parts, lambda out: self.convert(out, data_dir)))

    def data_files(self, loaded: PlainDataset) -> list[str]:  # type: ignore[override]  # given only its own load()
        return sorted(str(p) for p in loaded.folder.rglob("*") if p.is_file())


class BiotacSlide(CatalogDataset):
    """dexrob/BioTac_slide_20_50: one trial per slide, object and class = the material
    (:func:`~tzsl.datasets.convert_biotac_slide`; the catalog page gives its attributes' sources)."""

    name = BIOTAC_SLIDE
    description = ("20 materials x 50 BioTac slides (the raw 44-channel CSVs), one trial per slide; 3 attributes "
                   "from the release's material property document; per-channel signal statistics")
    source = (f"Gao et al. (IROS 2020); github.com/dexrob/BioTac_slide_20_50 at commit {BIOTAC_SLIDE_COMMIT[:7]}, "
              "fetched on first use")
    eps = ("slide",)
    registry_files = (BIOTAC_SLIDE_DIR,)
    package_files = (ATTRIBUTE_TABLE,)

    def convert(self, out, data_dir=None, *, force=False, signal_format="npz") -> Path:
        return convert_biotac_slide(out, data_dir, force=force, signal_format=signal_format)


class Bts3(CatalogDataset):
    """yayaneath/biotac-sp-images (BTS3): one trial per grasp, object and class = the grasped object, three
    fingertip sensors with their 24 electrode values as features (:func:`~tzsl.datasets.convert_bts3`;
    the catalog page gives its attributes' sources)."""

    name = BTS3
    description = ("41 objects x 2,549 Shadow-hand grasps, 3 BioTac SP fingertips (sensors ff, mf, th) x 24 "
                   "electrode values per grasp; 12 attributes from the object names and photo")
    source = (f"Zapata-Impata et al. (IROS 2018 workshop, arXiv:1809.05551); github.com/yayaneath/biotac-sp-images "
              f"at commit {BTS3_COMMIT[:7]}, fetched on first use")
    eps = ("grasp",)
    registry_files = (f"{BTS3}/",)
    package_files = (BTS3_TABLE,)

    def convert(self, out, data_dir=None, *, force=False, signal_format="npz") -> Path:
        return convert_bts3(out, data_dir, force=force)  # feature columns: no signal files to format


class IcubGrasp(CatalogDataset):
    """clear-nus/icub_grasp_dataset: one trial per grasp, object and class = the grasped object, one sensor
    ``hand`` (9 joint encoders and 5 x 12 fingertip readings per time slice); per-channel signal statistics
    (:func:`~tzsl.datasets.convert_icub_grasp`; the catalog page gives its attributes' sources)."""

    name = ICUB_GRASP
    description = ("9 objects x 20 iCub-hand grasps (9 joint encoders, 5 fingertips x 12 taxels per time slice), "
                   "one trial per grasp; 6 attributes from the README's object list; per-channel signal statistics")
    source = (f"Soh, Su and Demiris (IROS 2012); github.com/clear-nus/icub_grasp_dataset at commit "
              f"{ICUB_GRASP_COMMIT[:7]}, fetched on first use")
    eps = ("grasp",)
    registry_files = (ICUB_GRASP_DIR,)
    package_files = (ICUB_GRASP_TABLE,)

    def convert(self, out, data_dir=None, *, force=False, signal_format="npz") -> Path:
        return convert_icub_grasp(out, data_dir, force=force, signal_format=signal_format)


class Physiclear(CatalogDataset):
    """clear-nus/octopi (PhysiCLeAR): one trial per GelSight video, object and class = the object, one sensor
    ``gelsight`` whose features are texture descriptors of 5 key frames (:func:`~tzsl.datasets.convert_physiclear`;
    the catalog page gives its attributes' sources)."""

    name = PHYSICLEAR
    description = ("74 objects x 408 GelSight Mini videos (press and rotation), one trial per video; hardness, "
                   "roughness and bumpiness ranks (one attribute per level) and materials; texture descriptors of "
                   "5 key frames")
    source = (f"Yu et al. (RSS 2024, arXiv:2405.02794); github.com/clear-nus/octopi at commit "
              f"{PHYSICLEAR_COMMIT[:7]}, fetched on first use")
    eps = ("press-rotation",)
    registry_files = (f"{PHYSICLEAR}/",)  # the videos and utils/constants.py, the source of the shipped table
    package_files = (PHYSICLEAR_TABLE, PHYSICLEAR_SPLITS)
    ships_splits = True  # the paper's validation and test objects

    def convert(self, out, data_dir=None, *, force=False, signal_format="npz") -> Path:
        return convert_physiclear(out, data_dir, force=force)  # feature columns: no signal files to format


_DATASETS: dict[str, TactileDataset] = {}


def register_dataset(dataset: TactileDataset) -> TactileDataset:
    """Register a built-in dataset under its name; returns it (a taken name is a ValueError)."""
    if dataset.name in _DATASETS:
        raise ValueError(f"dataset {dataset.name!r} is already registered")
    _DATASETS[dataset.name] = dataset
    return dataset


def get_dataset(name: str) -> TactileDataset:
    """The registered dataset ``name``; a one-line ConfigError with the known names otherwise."""
    if name not in _DATASETS:
        raise ConfigError(f"unknown dataset {name!r}; choose one of {', '.join(_DATASETS)}")
    return _DATASETS[name]


def builtin_data_files(name: str) -> list[str]:
    """The registered files (paths relative to the data home) that ``[dataset] builtin = name`` reads.

    A built-in dataset's :attr:`TactileDataset.registry_files` (``hand-simulated``: none); a name
    that is a folder of the dataset registry (the fabric study's ``builtin = "fabric"``, which
    reads its groups, attribute matrices and depth images) every registered file of that folder;
    nothing for any other name.

    Returns
    -------
    list of str
        Sorted registered paths.
    """
    dataset = _DATASETS.get(name)
    prefixes = dataset.registry_files if dataset is not None else (f"{name}/",)
    return sorted({relpath for prefix in prefixes for relpath in registered_files(prefix)})


def dataset_names(*, convertible: bool | None = None) -> tuple[str, ...]:
    """Names of the registered datasets (``convertible=True``: those ``tzsl convert --dataset`` writes)."""
    return tuple(n for n, d in _DATASETS.items() if convertible is None or d.convertible == convertible)


register_dataset(Phac2Penn())
register_dataset(Phac2H5())
register_dataset(Phac2HoldMat())
register_dataset(FabricDepth())
register_dataset(HandSimulated())
register_dataset(BiotacSlide())
register_dataset(Bts3())
register_dataset(Physiclear())
register_dataset(IcubGrasp())
