"""filter_attributes: a min_objects that drops every attribute is an error naming the counts."""

from __future__ import annotations

import pandas as pd
import pytest

from tzsl.exceptions import ConfigError
from tzsl.features import filter_attributes


def test_dropping_every_attribute_is_an_error_with_counts():
    table = pd.DataFrame({"hard": [1, 1, 0], "soft": [0, 1, 1], "rough": [0, 0, 1]},
                         index=pd.Index(["a", "b", "c"], name="object_name"))
    with pytest.raises(ConfigError, match=r"min_objects=1000 drops every attribute: objects per attribute \(of 3\) "
                       r"are hard: 2, soft: 2, rough: 1; use min_objects <= 2"):
        filter_attributes(table, 1000)
    kept, dropped = filter_attributes(table, 2)
    assert list(kept.columns) == ["hard", "soft"] and dropped == ["rough"]
