"""Loading scenario files (docs/scenario.md) with one-line error reports.

Every mistake in a scenario, from an unreadable file to a foot without a
leg, becomes a `ScenarioError` whose text is `FILE: FIELD: what was expected`,
so the CLI can print it as is and exit 2.
"""

from __future__ import annotations

import datetime
import hashlib
import re
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from planner.scenario.model import Part, Region, Scenario
from planner.scenario.rules import FieldProblem

__all__ = ["Part", "Region", "Scenario", "ScenarioError", "load_scenario", "parse_scenario"]


# The largest scenario accepted: 1,000 parts take about 100 kB, so this is far
# above any real bench and far below what would stall parsing and validation.
MAX_SCENARIO_CHARS = 1_000_000


class ScenarioError(Exception):
    """A scenario that cannot be used; `str()` is one line `file: field: message`.

    `got` is the offending value as shown (`string 'abc'`), kept apart so that
    `without_value()` can say what is wrong without quoting the file, for
    readers who may not see the file itself (a dashboard's page).
    """

    def __init__(self, source: str, field: str, message: str, got: str | None = None) -> None:
        self.source = source
        self.field = field
        self.message = " ".join(message.split())  # one line, whatever the cause said
        self.got = None if got is None else " ".join(got.split())
        shown = self.message if self.got is None else f"{self.message}, got {self.got}"
        super().__init__(f"{source}: {field}: {shown}")

    def without_value(self) -> str:
        return f"{self.source}: {self.field}: {self.message}"


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; raises `ScenarioError`."""
    source = str(path)
    try:
        with Path(path).open("rb") as f:
            # One byte more than allowed is enough to refuse a huge file unread.
            data = f.read(MAX_SCENARIO_CHARS * 4 + 1)
    except OSError as err:
        raise ScenarioError(source, "file", f"cannot read: {err.strerror or err}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ScenarioError(source, "file", f"not UTF-8 text (byte {err.start})") from None
    return _parse(text, source, hashlib.sha256(data).hexdigest())


def parse_scenario(text: str, source: str) -> Scenario:
    """Validate scenario TOML `text`; `source` names it in errors."""
    return _parse(text, source, hashlib.sha256(text.encode("utf-8")).hexdigest())


def _parse(text: str, source: str, sha256: str) -> Scenario:
    if len(text) > MAX_SCENARIO_CHARS:
        raise ScenarioError(source, "file", f"too large (over {MAX_SCENARIO_CHARS:,} characters)")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise _toml_error(source, str(err)) from None
    except RecursionError:
        # tomllib parses nested arrays and inline tables recursively.
        raise ScenarioError(source, "toml", "nested too deeply") from None
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as err:
        first = err.errors(include_url=False)[0]
        raise ScenarioError(source, *_describe(first)) from None
    except RecursionError:
        raise ScenarioError(source, "toml", "nested too deeply") from None
    except FieldProblem as err:
        raise ScenarioError(source, err.path, err.message) from None
    scenario._sha256 = sha256
    return scenario


_AT = re.compile(r"\s*\(at (line (\d+), column (\d+)|end of document)\)\s*$")


def _toml_error(source: str, message: str) -> ScenarioError:
    # Python 3.11's TOMLDecodeError only carries the position inside its text.
    match = _AT.search(message)
    if match is None:
        return ScenarioError(source, "toml", f"invalid TOML: {message}")
    where = f"line {match[2]}, column {match[3]}" if match[2] else "end of file"
    what = message[: match.start()]
    return ScenarioError(source, where, f"invalid TOML: {what[:1].lower()}{what[1:]}")


def _path(loc: tuple[int | str, ...]) -> str:
    out = ""
    for item in loc:
        out += f"[{item}]" if isinstance(item, int) else (f".{item}" if out else item)
    return out or "(top level)"


_TOML_TYPES = {
    bool: "boolean",
    int: "integer",
    float: "float",
    str: "string",
    list: "array",
    dict: "table",
}
_EXPECTED = {
    "string_type": "expected a string",
    "bool_type": "expected true or false",
    "int_type": "expected an integer",
    "float_type": "expected a number",
    "list_type": "expected an array",
    "dict_type": "expected a table",
    "model_type": "expected a table",
    "missing": "missing (required)",
}
_LENGTH = re.compile(r"should have at (least|most) (\d+) items? after validation, not (\d+)")


def _describe(error: Any) -> tuple[str, str, str | None]:
    """(field path, plain words, the value as shown) for the first pydantic error."""
    loc: tuple[int | str, ...] = tuple(error["loc"])
    kind: str = error["type"]
    msg: str = error["msg"]
    if kind == "extra_forbidden":
        allowed = _fields_at(loc[:-1])
        hint = f" (allowed: {', '.join(allowed)})" if allowed else ""
        return _path(loc), f"unknown field{hint}", None
    if kind in _EXPECTED:
        what = _EXPECTED[kind]
    elif (m := _LENGTH.search(msg)) is not None:
        n = m[2]
        plural = "s" if n != "1" else ""
        return _path(loc), f"expected at {m[1]} {n} item{plural}, got {m[3]}", None
    elif msg.startswith("Value error, "):
        return _path(loc), msg.removeprefix("Value error, "), None
    else:
        what = msg.replace("Input should be ", "expected ", 1)
    return _path(loc), what, None if kind == "missing" else _show(error.get("input"))


def _show(value: object) -> str:
    name = _TOML_TYPES.get(type(value), type(value).__name__)
    if isinstance(value, dict | list):
        return f"an {name}" if name[0] in "aeiou" else f"a {name}"
    if isinstance(value, datetime.date | datetime.time):
        shown = value.isoformat()  # TOML's own spelling of dates and times
    else:
        shown = repr(value)
    return f"{name} {shown if len(shown) <= 40 else shown[:37] + '...'}"


def _fields_at(loc: tuple[int | str, ...]) -> list[str]:
    """The keys allowed in the table at `loc`, to suggest them after a typo."""
    tp: Any = Scenario
    for item in loc:
        tp = _unwrap(tp)
        if isinstance(item, str) and isinstance(tp, type) and issubclass(tp, BaseModel):
            field = next((f for n, f in tp.model_fields.items() if (f.alias or n) == item), None)
            if field is None:
                return []
            tp = field.annotation
        elif typing.get_origin(tp) in (list, dict):
            tp = typing.get_args(tp)[-1]
        else:
            return []
    tp = _unwrap(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [f.alias or n for n, f in tp.model_fields.items()]
    return []


def _unwrap(tp: Any) -> Any:
    # Strip Annotated[...] and `X | None` to get at the model or container type.
    while True:
        origin = typing.get_origin(tp)
        if origin is typing.Annotated:
            tp = typing.get_args(tp)[0]
        elif origin in (typing.Union, types.UnionType):
            tp = next(a for a in typing.get_args(tp) if a is not type(None))
        else:
            return tp
