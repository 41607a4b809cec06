"""The tasks' memory between generations: least recently used forgotten first."""

import pytest

from mjregen.tasks.cache import LRUCache


def test_the_least_recently_used_key_is_forgotten_first():
    cache = LRUCache(2)
    cache.put("a", 1)
    cache.put("b", 2)
    assert cache.get("a") == 1  # a is now more recent than b
    cache.put("c", 3)
    assert "b" not in cache and cache.get("a") == 1 and cache.get("c") == 3
    assert len(cache) == 2


def test_writing_a_known_key_replaces_its_value_and_makes_it_recent():
    cache = LRUCache(2)
    cache.put("a", 1)
    cache.put("b", 2)
    cache.put("a", 10)
    cache.put("c", 3)
    assert cache.get("a") == 10 and "b" not in cache


def test_an_unknown_key_reads_none_and_capacity_zero_remembers_nothing():
    cache = LRUCache(0)
    cache.put("a", 1)
    assert cache.get("a") is None and len(cache) == 0


@pytest.mark.parametrize("capacity", [-1, 1.5, True, "3"])
def test_a_capacity_that_is_not_a_whole_number_is_refused(capacity):
    with pytest.raises(ValueError, match="capacity"):
        LRUCache(capacity)
