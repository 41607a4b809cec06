"""What a task remembers between generations: results by key, the least recently used
forgotten first, so that the GA's elites and robots grown again are not evaluated again.

A task's configuration is frozen; its memory is not part of it (not compared, not stored in a
run folder): it only saves time, since every evaluation it saves gives the same result.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Hashable
from typing import Generic, TypeVar

Value = TypeVar("Value")


class LRUCache(Generic[Value]):
    """At most `capacity` values by key; reading or writing a key makes it the most recently
    used, and writing past `capacity` forgets the least recently used.

    Raises:
      ValueError: `capacity` is not a whole number >= 0.
    """

    def __init__(self, capacity: int) -> None:
        if isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 0:
            raise ValueError(f"a cache's capacity must be a whole number >= 0, got {capacity!r}")
        self.capacity = capacity
        self._values: OrderedDict[Hashable, Value] = OrderedDict()

    def __len__(self) -> int:
        return len(self._values)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._values

    def get(self, key: Hashable) -> Value | None:
        """The value of `key` (now the most recently used), or None."""
        if key not in self._values:
            return None
        self._values.move_to_end(key)
        return self._values[key]

    def put(self, key: Hashable, value: Value) -> None:
        """Remember `value` under `key` as the most recently used."""
        self._values[key] = value
        self._values.move_to_end(key)
        while len(self._values) > self.capacity:
            self._values.popitem(last=False)
