# SPDX-License-Identifier: Apache-2.0
"""`python -m swir_tracker_ros.param_files [REPO]`: regenerate every params/*.yaml file and every parameter
table in docs/ from the params dataclasses (the one source of each default, range and description).

A build tool over the whole package: it imports every layer's params and nothing imports it
(docs/interfaces.md, "Layers"). `test_param_files.py` checks that the files in the tree are generated.
"""

from __future__ import annotations

import sys
from pathlib import Path

from swir_tracker_ros.configs import ConfigurationChoice
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.demo import config as demo_config
from swir_tracker_ros.harness.store import REPO
from swir_tracker_ros.nodes import acquisition_node, positioner_node, tracker_endpoints, tracker_node
from swir_tracker_ros.nodes.param_docs import ParamsFile, markdown_table, marker, params_yaml, replace_block
from swir_tracker_ros.nodes.tracker_node_params import TrackerNodeParams
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.policies.lead import LeadParams
from swir_tracker_ros.policies.second import SecondParams
from swir_tracker_ros.simulation import scene_camera_node
from swir_tracker_ros.tracker import TrackerParams


def params_files() -> list[ParamsFile]:
    """Every params/*.yaml file of the package (each declared next to the node or command that reads it)."""
    return [tracker_node.PARAMS_FILE, positioner_node.PARAMS_FILE, acquisition_node.PARAMS_FILE,
            scene_camera_node.PARAMS_FILE, demo_config.PARAMS_FILE]


def documented_tables() -> list[tuple[str, type, str]]:
    """(docs file relative to the repository, params class, prefix) of every generated docs table."""
    return [("docs/tracker_node.md", TrackerNodeParams, ""),
            ("docs/tracker_node.md", ConfigurationChoice, "tracker."),
            ("docs/tracker_node.md", TrackerParams, "tracker."),
            ("docs/tracker_node.md", SiameseParams, "tracker.base."),
            ("docs/tracker_node.md", LeadParams, "tracker.lead."),
            ("docs/tracker_node.md", SecondParams, "tracker.lead.second."),
            ("docs/positioner.md", PositionerParams, "")]


def other_tables() -> list[tuple[str, str, str]]:
    """(docs file, marker line, generated table) of the generated tables that are not parameters."""
    return [("docs/tracker_node.md", tracker_endpoints.MARKER, tracker_endpoints.markdown_table())]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    repo = Path(args[0]) if args else REPO
    tables = [(rel, marker(cls, prefix), markdown_table(cls, prefix))
              for rel, cls, prefix in documented_tables()]
    for rel, mark, table in [*tables, *other_tables()]:
        path = repo / rel
        text = path.read_text()
        new = replace_block(text, mark, table)
        if new != text:
            path.write_text(new)
            print(f"updated {rel}: {mark[5:60]}...")
    for pf in params_files():
        path = repo / pf.path
        new = params_yaml(pf)
        if not path.is_file() or path.read_text() != new:
            path.write_text(new)
            print(f"updated {pf.path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
