"""Parameter sweeps: one scenario planned under every combination of varied settings.

`--vary safety=strict,normal` names a setting and its values; a bare name is a
`[preferences]` key, a dotted one any table's key (`human.initiative=0,1`). Each
variant is the scenario's own TOML with those keys replaced, validated like any
file, so a bad value is refused with the scenario's usual message.
`plan_variant` plans and audits one variant and returns its row: the paper's
columns, the planning times and the audit's verdict.
"""

from __future__ import annotations

import itertools
import time
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tomli_w

from planner.audit.branches import audit
from planner.plan.model import STAT_KEYS
from planner.planning import plan_scenario
from planner.scenario.loading import parse_scenario
from planner.search.errors import DeadEnd

Value = str | int | float | bool
ROW_KEYS = (*STAT_KEYS, "first_branch_s", "plan_s", "checks_s", "violations", "error")


@dataclass(frozen=True)
class Variation:
    """A setting (`preferences.safety`) and the values it takes, in the order given."""

    key: str
    values: tuple[Value, ...]

    @property
    def name(self) -> str:
        """The short name used in columns and labels: the key after its table."""
        return self.key.rsplit(".", 1)[-1]


@dataclass(frozen=True)
class Variant:
    """One scenario with one value per variation, as TOML text ready to plan."""

    scenario: str  # the scenario's name
    settings: tuple[tuple[str, Value], ...]  # (variation name, value)
    text: str


def parse_variation(spec: str) -> Variation:
    """`KEY=V1,V2,...` -> Variation; raises ValueError with what was expected."""
    key, sep, values = spec.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise ValueError(f"--vary {spec!r}: expected KEY=VALUE1,VALUE2 (e.g. safety=strict,normal)")
    if "." not in key:
        key = f"preferences.{key}"
    parsed = tuple(_value(v.strip()) for v in values.split(",") if v.strip())
    if len(set(parsed)) != len(parsed):
        raise ValueError(f"--vary {spec!r}: a value is repeated")
    return Variation(key, parsed)


def variants(name: str, text: str, variations: Sequence[Variation]) -> list[Variant]:
    """Every combination of the variations' values applied to scenario `text`, in order
    (the first variation varies slowest)."""
    names = [v.name for v in variations]
    if len(set(names)) != len(names):
        raise ValueError(f"two variations share a name: {', '.join(names)}")
    base = tomllib.loads(text)
    out = []
    for combo in itertools.product(*(v.values for v in variations)):
        doc = _copy(base)
        for variation, value in zip(variations, combo, strict=True):
            *tables, leaf = variation.key.split(".")
            table = doc
            for t in tables:
                table = table.setdefault(t, {})
                if not isinstance(table, dict):
                    raise ValueError(f"--vary {variation.key}: {t} is not a table")
            table[leaf] = value
        variant_text = tomli_w.dumps(doc)
        settings = tuple(zip(names, combo, strict=True))
        label = ", ".join(f"{k}={v}" for k, v in settings)
        parse_scenario(variant_text, f"{name} ({label})")  # refuse bad values before planning
        out.append(Variant(name, settings, variant_text))
    return out


def plan_variant(variant: Variant, cache_dir: Path | str | None = None) -> dict[str, Any]:
    """Plans and audits one variant on one core; the row of the sweep's table."""
    label = ", ".join(f"{k}={v}" for k, v in variant.settings)
    scenario = parse_scenario(variant.text, f"{variant.scenario} ({label})")
    row: dict[str, Any] = {"scenario": variant.scenario, **dict(variant.settings)}
    row.update(dict.fromkeys(ROW_KEYS))
    t0 = time.perf_counter()
    try:
        result = plan_scenario(scenario, workers=1, cache_dir=cache_dir)
    except DeadEnd as err:
        row["plan_s"] = round(time.perf_counter() - t0, 3)
        row["error"] = f"no plan: {err}"
        return row
    stats = result.plan.statistics
    row.update({k: stats[k] for k in STAT_KEYS})
    row["first_branch_s"] = round(result.first_branch_s, 3)
    row["plan_s"] = stats["plan_s"]
    row["checks_s"] = stats["checks_s"]
    row["violations"] = len(audit(result.plan.to_json()))
    return row


def _value(text: str) -> Value:
    """TOML's own reading of a bare value (1, 0.5, true), else the text itself."""
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    return value if isinstance(value, str | int | float | bool) else text


def _copy(doc: dict[str, Any]) -> dict[str, Any]:
    return tomllib.loads(tomli_w.dumps(doc))
