# SPDX-License-Identifier: Apache-2.0
"""The base filters by name: the one registry a new base filter is added to (docs/tracking_core.md)."""

from __future__ import annotations

from swir_tracker_ros.core.base import BaseFilter, FilterParams
from swir_tracker_ros.core.eco.base import ECOBase
from swir_tracker_ros.core.filters import BACFFilter, DCFCAFilter, KCFFilter
from swir_tracker_ros.core.siamese.base import SiameseBase
from swir_tracker_ros.errors import ParameterError

BASE_FILTERS: dict[str, type[BaseFilter]] = {
    cls.name: cls for cls in (KCFFilter, DCFCAFilter, BACFFilter, ECOBase, SiameseBase)
}
"""Every base filter by its `name` (`configuration(name, base)`, ROS `tracker.base_filter`); the first is
the papers' (paper 000: KCF)."""


def filter_params(name: str) -> FilterParams:
    """The default Params of the base filter `name` (ParameterError naming the known ones)."""
    try:
        return BASE_FILTERS[name].Params()
    except KeyError:
        raise ParameterError(f"unknown base filter {name!r}; known: {', '.join(BASE_FILTERS)}") from None


def filter_class(fp: FilterParams) -> type[BaseFilter]:
    """The base filter class whose Params `fp` is (ParameterError if none)."""
    for cls in BASE_FILTERS.values():
        if type(fp) is cls.Params:
            return cls
    known = ", ".join(cls.Params.__name__ for cls in BASE_FILTERS.values())
    raise ParameterError(f"no base filter takes {type(fp).__name__} (known: {known})")


def make_filter(fp: FilterParams, w: float, h: float) -> BaseFilter:
    """The base filter whose Params `fp` is, for a first box of size w x h (ParameterError if none)."""
    return filter_class(fp)(fp, w, h)
