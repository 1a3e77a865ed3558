"""A System's memo: what is computed from one System and a few hashable arguments, kept with it."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

T = TypeVar("T")


class Memo:
    """Values keyed by what they were computed from: one per System (`System.memo`, never shared with a
    copy; as many entries as the System is asked for, a few variants and steps), or one of a process
    bounded by `maxsize` (the least recently used dropped: it is made again when asked for)."""

    def __init__(self, maxsize: int | None = None) -> None:
        self._values: OrderedDict[Hashable, Any] = OrderedDict()
        self.maxsize = maxsize

    def get(self, key: Hashable, make: Callable[[], T]) -> T:
        """The value of `key`, made by `make()` the first time it is asked for (or after it was dropped)."""
        if key in self._values:
            self._values.move_to_end(key)
        else:
            self._values[key] = make()
            if self.maxsize is not None and len(self._values) > self.maxsize:
                self._values.popitem(last=False)
        value: T = self._values[key]
        return value

    def set(self, key: Hashable, value: object) -> None:
        """`key`'s value from now on (the most recently used), replacing any."""
        self._values.pop(key, None)
        self._values[key] = value
        if self.maxsize is not None and len(self._values) > self.maxsize:
            self._values.popitem(last=False)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._values

    def __len__(self) -> int:
        return len(self._values)
