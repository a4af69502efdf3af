"""Reading a YAML file with one-line errors that name the file and the problem."""
from __future__ import annotations

from typing import Any, Type

import yaml

from .errors import BulletFloorSimError

__all__ = ["read_yaml"]


def read_yaml(path: str, kind: str, error: Type[BulletFloorSimError]) -> Any:
    """Parse a YAML file.

    Args:
        path: the file.
        kind: what the file is, for messages ("map", "world", "ROI").
        error: the exception class to raise.

    Returns:
        The parsed document (any YAML value; callers check its shape).

    Raises:
        error: ``<path>: <kind> file not found``, ``<path>: cannot read <kind> file: <why>``,
            ``<path>: not a text <kind> file (...)`` or ``<path>: not valid YAML (line N)``.
    """
    try:
        with open(path, "r") as f:
            return yaml.safe_load(f)
    except FileNotFoundError:
        raise error("%s: %s file not found" % (path, kind)) from None
    except OSError as e:
        raise error("%s: cannot read %s file: %s" % (path, kind, e.strerror)) from None
    except UnicodeDecodeError as e:
        raise error("%s: not a text %s file (byte 0x%02x at offset %d is not UTF-8)"
                    % (path, kind, e.object[e.start], e.start)) from None
    except yaml.YAMLError as e:
        line = getattr(getattr(e, "problem_mark", None), "line", None)
        where = " (line %d)" % (line + 1) if line is not None else ""
        raise error("%s: not valid YAML%s" % (path, where)) from None
