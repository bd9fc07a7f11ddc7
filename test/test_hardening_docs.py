# SPDX-License-Identifier: Apache-2.0
"""Issue 14, item 5: the parameter tables in docs/ are the ones generated from the params dataclasses
(`python -m swir_tracker_ros.param_files` rewrites them), nested dataclasses included."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest
from conftest import REPO

from swir_tracker_ros.nodes.param_docs import (
    markdown_rows,
    marker,
    replace_table,
    usage_lines,
    walk,
)
from swir_tracker_ros.nodes.tracker_node import usage
from swir_tracker_ros.param_files import documented_tables
from swir_tracker_ros.tracker import TrackerParams


@pytest.mark.parametrize("doc,cls,prefix", documented_tables(),
                         ids=[f"{d}:{c.__name__}" for d, c, _ in documented_tables()])
def test_docs_tables_match_the_dataclasses(doc: str, cls: type, prefix: str) -> None:
    text = (REPO / doc).read_text()
    assert marker(cls, prefix) in text, f"{doc} lacks the table marker of {cls.__name__}"
    assert replace_table(text, cls, prefix) == text, (
        f"{doc}: the {cls.__name__} table differs from the dataclass; run "
        "`.venv/bin/python -m swir_tracker_ros.param_files`")


def test_tracker_feature_default_is_the_code_default() -> None:
    """The drift the issue found: the doc said 'hog' while the code and params file said 'hog_soft'."""
    text = (REPO / "docs" / "tracker_node.md").read_text()
    rows = markdown_rows(TrackerParams, "tracker.")
    row = next(r for r in rows if r.startswith("| `tracker.base.feature` |"))
    assert f"`{TrackerParams().base.feature!r}`" in row and row in text


@dataclass
class _Inner:
    padding: float = field(default=1.5, metadata={"doc": "window padding", "min": 0.5, "max": 4.0})
    kind: str = field(default="a", metadata={"doc": "kind", "choices": ("a", "b")})


@dataclass
class _Outer:
    variant: str = field(default="x", metadata={"doc": "variant | with a bar"})
    kcf: _Inner = field(default_factory=_Inner, metadata={"doc": "nested"})
    rate: int = field(default=3, metadata={"doc": "rate", "min": 1})


def test_nested_dataclasses_become_dotted_rows_and_usage_lines() -> None:
    assert [p.name for p in walk(_Outer, "tracker.")] == [
        "tracker.variant", "tracker.kcf.padding", "tracker.kcf.kind", "tracker.rate"]
    rows = markdown_rows(_Outer, "tracker.")
    assert rows[1] == "| `tracker.kcf.padding` | float | `1.5` | [0.5, 4.0] | window padding |"
    assert rows[2] == "| `tracker.kcf.kind` | str | `'a'` | `a`, `b` | kind |"
    assert rows[0].endswith("| variant \\| with a bar |") and rows[3].endswith("| [1, inf] | rate |")
    assert "  tracker.kcf.padding (default 1.5): window padding" in usage_lines(_Outer, "tracker.")
    doc = f"# t\n\n{marker(_Outer, 'tracker.')}\n| old |\n|---|\n| `stale` |\n\nafter\n"
    new = replace_table(doc, _Outer, "tracker.")
    assert "`stale`" not in new and "| `tracker.kcf.kind` |" in new and new.endswith("\n\nafter\n")
    assert replace_table(new, _Outer, "tracker.") == new


def test_tracker_usage_lists_every_parameter() -> None:
    text = usage()
    for p in walk(TrackerParams, "tracker."):
        assert f"  {p.name} (default " in text
