"""Config dataclasses changed field by field from text or parameter values: the nodes'
``~<field>`` parameters (ros/params.py) and the studies' ``--set section.field=value``
(bench/eval_worlds.py)."""
from __future__ import annotations

import dataclasses
from typing import Any, Dict, TypeVar

from .errors import ConfigError

__all__ = ["convert", "with_changes"]

C = TypeVar("C")


def convert(name: str, value: Any, current: Any) -> Any:
    """``value`` as the type of ``current`` (any value when that is None), taking what
    roslaunch makes of a ``<param value="...">`` (it types "1e3" and "inf" as strings, and
    a bool written 1 or 0 as an int), but never a word for a bool or a number ("false" is
    not True)."""
    if current is None:
        return value
    want = type(current)
    if want is bool:
        if isinstance(value, bool):
            return value
        word = str(value).strip().lower()
        if isinstance(value, (int, str)) and word in ("1", "0", "true", "false"):
            return word in ("1", "true")
        raise ConfigError("%s: expected true or false, got %r" % (name, value))
    if want in (int, float):
        number = value
        if isinstance(value, str):
            try:
                number = float(value)
            except ValueError:
                raise ConfigError("%s: expected a number, got %r" % (name, value)) from None
        if isinstance(number, bool) or not isinstance(number, (int, float)):
            raise ConfigError("%s: expected a number, got %r" % (name, value))
        if want is int and not float(number).is_integer():
            raise ConfigError("%s: expected a whole number, got %r" % (name, value))
        return want(number)
    if want is list and not isinstance(value, list):
        raise ConfigError("%s: expected a list, got %r" % (name, value))
    return want(value)


def with_changes(config: C, changes: Dict[str, Any], prefix: str = "") -> C:
    """A copy of the dataclass ``config`` with each of ``changes`` (field -> value, text
    or typed) converted to its field's current type; its ``check()`` run.

    Raises:
        ConfigError: a name that is no field of it, or a value that cannot be converted
            (named ``<prefix><field>``).
        the config's own error (a BulletFloorSimError naming the field) for a bad value.
    """
    fields = {f.name for f in dataclasses.fields(config)}   # type: ignore[arg-type]
    typed = {}
    for k, v in changes.items():
        if k not in fields:
            raise ConfigError("%s%s: no such parameter (%s has: %s)"
                              % (prefix, k, type(config).__name__, ", ".join(sorted(fields))))
        typed[k] = convert(prefix + k, v, getattr(config, k))
    out = dataclasses.replace(config, **typed)   # type: ignore[type-var]
    check = getattr(out, "check", None)
    if check is not None:
        check()
    return out
