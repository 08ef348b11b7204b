"""``make reproduce-tables``: every table and figure of both papers from the real data.

Writes into one results folder:

* the PHAC-2 DAP study (:mod:`tzsl.experiments.phac2_dap`): ``table1_fusion.csv``,
  ``table2_priors.csv``, ``table3_challenging.csv``, ``multilabel.csv``,
  ``attribute_accuracy.csv``, ``attribute_sweep.csv``, ``phac2_methods.csv`` and the PNG
  figures ``attribute_accuracy.png``, ``object_map.png``, ``attribute_sweep.png``;
* the fabric study (:mod:`tzsl.experiments.fabric`): ``fabric_table1.csv`` and its figure;
* the hand study on **simulated** grasps (:mod:`tzsl.experiments.hand`; the Shadow-hand data of
  the paper are not public): ``hand_table5.csv`` and its curves;
* ``manifest.json``: configuration, seeds, data checksums, package versions and a checksum of
  every output (the fabric and hand studies also write their own ``*_manifest.json``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from tzsl.experiments._outputs import ResultsDir
from tzsl.experiments.phac2_dap import DapStudyConfig, run_dap_study

DAP_OUTPUTS = (
    "table1_fusion.csv", "table2_priors.csv", "table3_challenging.csv", "multilabel.csv",
    "attribute_accuracy.csv", "attribute_accuracy_per_split.csv", "attribute_sweep.csv", "object_map.csv",
    "phac2_methods.csv", "attribute_accuracy.png", "attribute_sweep.png", "object_map.png", "manifest.json",
)


def reproduce_tables(
    out: str | Path,
    data_dir: str | Path | None = None,
    config: DapStudyConfig | None = None,
    force: bool = False,
    hand_seeds: tuple[int, ...] = (0, 1, 2, 3, 4),
    fabric_seeds: int = 5,
    echo: Callable[[str], None] | None = None,
) -> ResultsDir:
    """Run the PHAC-2, fabric and hand studies into ``out``; returns the results folder."""
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415
    from tzsl.experiments.extract import extract_features  # noqa: PLC0415
    from tzsl.experiments.fabric import run_fabric_study  # noqa: PLC0415
    from tzsl.experiments.hand import run_hand_study  # noqa: PLC0415

    say = echo or (lambda _msg: None)
    config = config or DapStudyConfig()
    results = ResultsDir(out, force=force)
    results.check_free(DAP_OUTPUTS)
    timings: dict[str, float] = {}

    start = time.perf_counter()
    features = extract_features("phac2-penn", data_dir=data_dir)
    say(f"PHAC-2: {features.n_trials} trials, {features.n_objects} objects, {len(features.attributes.columns)} "
        "attributes")
    tables = run_dap_study(features, results, config, kinds=("random", "challenging"), sweep=True,
                           compare_methods=True, echo=echo)
    timings["phac2_dap_s"] = time.perf_counter() - start

    start = time.perf_counter()
    fabric = run_fabric_study(results, data_dir=data_dir, seeds=fabric_seeds, progress=config.progress,
                              n_jobs=config.n_jobs)
    if echo and "fabric_table1" in fabric:
        echo("\nFabric Table 1 analogue (depth images) - ours beside the paper's")
        echo(fabric["fabric_table1"].to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-"))
    timings["fabric_s"] = time.perf_counter() - start

    start = time.perf_counter()
    hand = run_hand_study(None, load_hand_table4(), results, seeds=hand_seeds, force=force, log=None)
    if echo:
        from tzsl.experiments.hand import format_hand_summary  # noqa: PLC0415

        echo("\nHand study on SIMULATED grasps (the paper's Shadow-hand data are not public)")
        echo(format_hand_summary(hand))
    timings["hand_s"] = time.perf_counter() - start

    results.write_manifest(
        {"phac2_dap": asdict(config), "fabric_seeds": fabric_seeds, "hand_seeds": list(hand_seeds),
         "hand_data": "simulated"},
        data_files=features.info.get("data_files", []),
        extra={"timings_s": timings, "tables": sorted(tables)},
    )
    return results
