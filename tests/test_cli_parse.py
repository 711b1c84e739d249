"""The --lock and --keep arguments: values parse, and every bad item is refused as bad input."""

from __future__ import annotations

import pytest

from robodyn.cli._parse import parse_keep, parse_lock
from robodyn.errors import InputError


def test_parse_lock_and_keep():
    assert parse_lock("a=0.1, b=-2") == {"a": 0.1, "b": -2.0}
    assert parse_keep("a, b") == ("a", "b")


@pytest.mark.parametrize(
    ("text", "message"),
    [("a", "name=value"), ("a=x", "a number"), ("=1", "name=value"), ("a=nan", "finite"), ("", "at least one")],
)
def test_bad_lock_items_are_named(text, message):
    with pytest.raises(InputError, match=message):
        parse_lock(text)


def test_keep_needs_a_name():
    with pytest.raises(InputError, match="at least one"):
        parse_keep(" , ")
