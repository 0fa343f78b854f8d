"""What the panels need of viser's widgets beyond what its types say."""

from __future__ import annotations

from typing import Protocol, TypeVar

T = TypeVar("T")
T_co = TypeVar("T_co", covariant=True)


class Input(Protocol[T_co]):
    """A viser input: a dropdown, a text, a checkbox, a slider, a progress bar."""

    @property
    def value(self) -> T_co: ...


def show(handle: Input[T], value: T) -> None:
    """Make `handle` show `value` in every page; its update callbacks run, as for a
    change made in a page. viser has a setter for `value`, but mypy takes the
    property as read-only (viser defines a method between its getter and setter)."""
    handle.value = value  # type: ignore[misc]
