"""Value checks shared by the world file's sections (config.py and each sensor's section)."""
from __future__ import annotations

import math
from typing import Any, Mapping, Tuple

from ..errors import ConfigError

__all__ = ["is_number", "finite_positive", "positive", "reject_unknown"]


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
