"""Value checks shared by the world file's sections (config.py and each sensor's section)."""
from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, ClassVar, Dict, Mapping, Protocol, Tuple, Type, TypeVar

from ..errors import ConfigError

__all__ = ["is_number", "finite_positive", "positive", "reject_unknown", "section"]


def is_number(v: Any) -> bool:
    """An int or float, not a bool."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def finite_positive(v: Any) -> bool:
    """A finite number > 0."""
    return is_number(v) and math.isfinite(v) and v > 0


def positive(obj: Any, where: str, names: Tuple[str, ...]) -> None:
    """Raise ConfigError naming ``where`` and the first of ``names`` (attributes of ``obj``)
    that is not a finite number > 0."""
    for k in names:
        v = getattr(obj, k)
        if not finite_positive(v):
            raise ConfigError("%s: %s must be a positive number, got %r" % (where, k, v))


def reject_unknown(doc: Mapping[str, Any], known: Tuple[str, ...], where: str) -> None:
    """Raise ConfigError naming ``where`` and every key of ``doc`` not in ``known``."""
    unknown = sorted(str(k) for k in doc if k not in known)
    if unknown:
        raise ConfigError("%s: unknown key(s) %s (known: %s)"
                          % (where, ", ".join(repr(k) for k in unknown), ", ".join(known)))


class Section(Protocol):
    """A world.yaml section's class: a dataclass whose fields are the keys, with defaults,
    and ``validate(where)`` raising ConfigError."""

    __dataclass_fields__: ClassVar[Dict[str, Any]]

    def validate(self, where: str) -> None:
        ...


T = TypeVar("T", bound=Section)


def section(cls: Type[T], doc: Any, where: str) -> T:
    """A world.yaml section (``doc``: None or a mapping) read into ``cls``: its fields are
    the keys with their defaults; a float field takes any finite number. Raises ConfigError
    naming ``where`` and the key."""
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError("%s: expected a mapping, got %r" % (where, doc))
    defaults: Dict[str, Any] = {f.name: f.default for f in fields(cls)}
    reject_unknown(doc, tuple(defaults), where)
    values: Dict[str, Any] = {}
    for k, v in doc.items():
        want = type(defaults[k])
        if want is float and is_number(v):
            v = float(v)
        if not isinstance(v, want) or (want is float and not math.isfinite(v)):
            raise ConfigError("%s: %s must be %s, got %r"
                              % (where, k, "a finite number" if want is float else want.__name__, v))
        values[k] = v
    obj = cls(**values)
    obj.validate(where)
    return obj
