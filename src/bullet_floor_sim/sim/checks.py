"""Value checks shared by the world file's sections (config.py and each sensor's section),
the config dataclasses of the core (follower, predictor, tracker, walker, crowd, path
follower, evaluation, gym) and the nodes' ``~<name>`` parameters (``prefix="~"``), with one
wording for a field out of range: ``<owner>: <name> must be a finite number > 0, got -1``
(``... a finite number of seconds > 0`` where a unit is given)."""
from __future__ import annotations

import math
from dataclasses import fields
from numbers import Integral, Real
from typing import Any, ClassVar, Dict, Iterable, Mapping, Optional, Protocol, Tuple, Type, TypeVar

from ..errors import BulletFloorSimError, ConfigError

__all__ = ["is_number", "finite_positive", "check_numbers", "check_integers", "reject_unknown",
           "section"]


def is_number(v: Any) -> bool:
    """A real number (an int, a float or numpy's), not a bool."""
    return isinstance(v, Real) and not isinstance(v, bool)


def finite_positive(v: Any) -> bool:
    """A finite number > 0."""
    return is_number(v) and math.isfinite(v) and v > 0


def check_numbers(config: Any, names: Iterable[str], owner: str,
                  least: Optional[float] = 0.0, strict: bool = True,
                  error: Type[BulletFloorSimError] = ConfigError, prefix: str = "",
                  unit: str = "") -> None:
    """Raise ``error`` for the first of ``names`` (attributes of ``config``) that is not a
    finite number above ``least`` (at or above it unless ``strict``; any finite number when
    ``least`` is None): ``<owner>: <prefix><name> must be a finite number[ of <unit>] > <least>,
    got <value>``."""
    for name in names:
        v = getattr(config, name)
        if is_number(v) and math.isfinite(v) and (
                least is None or (v > least if strict else v >= least)):
            continue
        bound = "" if least is None else " %s %g" % (">" if strict else ">=", least)
        raise error("%s: %s%s must be a finite number%s%s, got %r"
                    % (owner, prefix, name, " of " + unit if unit else "", bound, v))


def check_integers(config: Any, names: Iterable[str], owner: str, least: int = 1,
                   error: Type[BulletFloorSimError] = ConfigError, prefix: str = "") -> None:
    """Raise ``error`` for the first of ``names`` that is not an integer (not a bool) at or
    above ``least``: ``<owner>: <prefix><name> must be an integer >= <least>, got <value>``."""
    for name in names:
        v = getattr(config, name)
        if not (isinstance(v, Integral) and not isinstance(v, bool) and int(v) >= least):
            raise error("%s: %s%s must be an integer >= %d, got %r" % (owner, prefix, name, least, v))


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
