"""The ``people:`` section of a world.yaml: who walks, by which regions' chain, how fast.

::

    people:
      count: 20                 # people in one group (or give ``groups:``)
      rois: rois.yaml           # their regions (default: the world's ``rois``)
      dwell: [5.0, 20.0]        # seconds spent at each goal, uniform in [min, max]
      speed: [0.8, 1.5]         # preferred walking speed (m/s), drawn per person
      seed: 1                   # people's random streams (None: fresh every run)
      rate: 20.0                # Hz the crowd is stepped at
      groups:                   # instead of count: a list of groups, each with count and
        - {count: 5, name: visitor, speed: [0.8, 1.0]}   # any of rois, dwell, speed, seed,
        - {count: 3, name: family, together: true}       # together (one party: groups.py)
      body: {radius: 0.25, leg_radius: 0.06, ...}        # BodyConfig
      forces: {strength: 2.0, ...}                       # forces.ForceConfig

A person is named ``<group name>_<n>`` (``person_1``, ``person_2``, ... by default), numbered
across the groups in file order.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields, replace
from typing import Any, Dict, Optional, Tuple

from ...errors import ConfigError
from ...sim.checks import check_numbers, is_number, reject_unknown as _reject_unknown, section as _section
from .forces import ForceConfig

__all__ = ["BodyConfig", "GroupConfig", "PeopleConfig", "parse_people"]


@dataclass(frozen=True)
class BodyConfig:
    """A person's body (metres).

    Attributes:
        radius: half the shoulder width: the disc people and robots keep clear of.
        leg_radius: a leg's radius where the lidar sees it (a 0.12 m thick leg).
        leg_spacing: the legs' centres, left to right, standing.
        step_length: distance walked per step: the gait advances half a cycle per step.
        swing: how far each leg is ahead of or behind the hips at full stride.
        leg_height: lasers above this see no legs (the body above the knees is not modelled).
    """

    radius: float = 0.25
    leg_radius: float = 0.06
    leg_spacing: float = 0.2
    step_length: float = 0.7
    swing: float = 0.15
    leg_height: float = 0.8

    def validate(self, where: str) -> None:
        """Raise ConfigError naming the first bad value."""
        check_numbers(self, [f.name for f in fields(self)], where)
        if self.leg_spacing + 2 * self.leg_radius > 2 * self.radius:
            raise ConfigError("%s: the legs (leg_spacing %g + 2 x leg_radius %g) must fit in the "
                              "body (2 x radius %g)" % (where, self.leg_spacing, self.leg_radius,
                                                        self.radius))


@dataclass(frozen=True)
class GroupConfig:
    """People who share regions, dwell times and a speed range.

    Attributes:
        count: how many.
        name: their names' prefix.
        rois: the ROI file whose regions' chain they walk (absolute; None: the world's).
        dwell: (min, max) seconds at each goal.
        speed: (min, max) preferred speed, m/s; each person's is drawn uniformly.
        seed: the group's random streams (None: the section's seed, offset by the group).
        together: they walk as one party: the first leads by the chain, the others follow
            it at its speed and keep together (groups.py).
    """

    count: int = 1
    name: str = "person"
    rois: Optional[str] = None
    dwell: Tuple[float, float] = (5.0, 20.0)
    speed: Tuple[float, float] = (0.8, 1.5)
    seed: Optional[int] = None
    together: bool = False


@dataclass(frozen=True)
class PeopleConfig:
    """The parsed ``people:`` section."""

    groups: Tuple[GroupConfig, ...] = ()
    rate: float = 20.0
    seed: Optional[int] = None
    body: BodyConfig = BodyConfig()
    forces: ForceConfig = field(default_factory=ForceConfig)

    @property
    def count(self) -> int:
        """People in all groups."""
        return sum(g.count for g in self.groups)

    def with_count(self, n: int) -> "PeopleConfig":
        """``n`` people, all of the first group's kind (``people:=N`` of the launch files);
        0 people when ``n`` is 0."""
        if n < 0:
            raise ConfigError("people: the number of people must be >= 0, got %d" % n)
        first = self.groups[0] if self.groups else GroupConfig()
        return replace(self, groups=(replace(first, count=n),) if n else ())


_TOP_KEYS = ("count", "name", "rois", "dwell", "speed", "seed", "together", "rate", "groups",
             "body", "forces")
_GROUP_KEYS = ("count", "name", "rois", "dwell", "speed", "seed", "together")


def parse_people(doc: Any, where: str, base_dir: str) -> PeopleConfig:
    """Parse a ``people:`` section (None or empty: no people).

    Args:
        doc: the section as read from YAML.
        where: the file, for messages.
        base_dir: what relative ``rois`` paths are relative to.

    Raises:
        ConfigError: a key is unknown or a value bad; the message names the file and key.
    """
    if doc is None:
        return PeopleConfig()
    where = "%s: people" % where
    if not isinstance(doc, dict):
        raise ConfigError("%s: expected a mapping with keys %s, got %r"
                          % (where, ", ".join(_TOP_KEYS), doc))
    _reject_unknown(doc, _TOP_KEYS, where)
    if "groups" in doc and "count" in doc:
        raise ConfigError("%s: give either count or groups, not both" % where)
    seed = _seed(doc.get("seed"), where)
    rate = doc.get("rate", 20.0)
    if not _number(rate) or not rate > 0:
        raise ConfigError("%s: rate must be a number of Hz > 0, got %r" % (where, rate))
    defaults = _group({k: v for k, v in doc.items() if k in _GROUP_KEYS and k != "count"},
                      where, base_dir, GroupConfig(count=0))
    groups_doc = doc.get("groups")
    groups: Tuple[GroupConfig, ...]
    if groups_doc is None:
        groups = (replace(defaults, count=_count(doc.get("count", 0), where)),)
    elif not isinstance(groups_doc, list):
        raise ConfigError("%s: groups must be a list, got %r" % (where, groups_doc))
    else:
        groups = tuple(_group(g, "%s: groups[%d]" % (where, i), base_dir, defaults)
                       for i, g in enumerate(groups_doc))
    body = _section(BodyConfig, doc.get("body"), "%s: body" % where)
    forces = _section(ForceConfig, doc.get("forces"), "%s: forces" % where)
    return PeopleConfig(groups=tuple(g for g in groups if g.count), rate=float(rate),
                        seed=seed, body=body, forces=forces)


def _group(doc: Any, where: str, base_dir: str, defaults: GroupConfig) -> GroupConfig:
    if not isinstance(doc, dict):
        raise ConfigError("%s: expected a mapping with keys %s, got %r"
                          % (where, ", ".join(_GROUP_KEYS), doc))
    _reject_unknown(doc, _GROUP_KEYS, where)
    values: Dict[str, Any] = {}
    if "count" in doc:
        values["count"] = _count(doc["count"], where)
    if "name" in doc:
        name = doc["name"]
        if not (isinstance(name, str) and name.isidentifier()):
            raise ConfigError("%s: name must be a word ([A-Za-z_][A-Za-z0-9_]*), got %r"
                              % (where, name))
        values["name"] = name
    if "rois" in doc:
        if not isinstance(doc["rois"], str) or not doc["rois"]:
            raise ConfigError("%s: rois must be a file name, got %r" % (where, doc["rois"]))
        values["rois"] = os.path.normpath(os.path.join(base_dir, os.path.expanduser(doc["rois"])))
    for key, low in (("dwell", 0.0), ("speed", 0.2)):
        if key in doc:
            values[key] = _range(doc[key], low, where, key)
    if "seed" in doc:
        values["seed"] = _seed(doc["seed"], where)
    if "together" in doc:
        if not isinstance(doc["together"], bool):
            raise ConfigError("%s: together must be true or false, got %r"
                              % (where, doc["together"]))
        values["together"] = doc["together"]
    return replace(defaults, **values)


def _range(v: Any, low: float, where: str, key: str) -> Tuple[float, float]:
    if (not isinstance(v, (list, tuple)) or len(v) != 2 or not all(_number(x) for x in v)
            or not low <= v[0] <= v[1] or not math.isfinite(v[1])):
        raise ConfigError("%s: %s must be [min, max] with %g <= min <= max, got %r"
                          % (where, key, low, v))
    return (float(v[0]), float(v[1]))


def _count(v: Any, where: str) -> int:
    if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
        raise ConfigError("%s: count must be an integer >= 0, got %r" % (where, v))
    return int(v)


def _seed(v: Any, where: str) -> Optional[int]:
    if v is None:
        return None
    if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
        raise ConfigError("%s: seed must be an integer >= 0, got %r" % (where, v))
    return int(v)


def _number(v: Any) -> bool:
    return is_number(v) and math.isfinite(v)
