"""The map -> N/odom transforms the simulator publishes from ground truth (without amcl)."""
from __future__ import annotations

import math
from typing import Any, List, Tuple

from ...errors import ConfigError

__all__ = ["gt_tf_robots", "map_to_odom"]


def map_to_odom(truth, odom) -> Tuple[float, float, float]:
    """map -> N/odom that makes odom -> base_footprint land on the ground truth (what
    fake_localization does); only when no localisation node (amcl) publishes it."""
    xg, yg, thg = truth
    xo, yo, tho = odom
    th = thg - tho
    c, s = math.cos(th), math.sin(th)
    return xg - (c * xo - s * yo), yg - (s * xo + c * yo), th



def gt_tf_robots(setting: Any, names: List[str]) -> List[int]:
    """Indices of the robots whose map -> N/odom comes from ground truth (``~ground_truth_tf``:
    a bool, or a list of robot names)."""
    if isinstance(setting, (list, tuple)):
        unknown = sorted(set(map(str, setting)) - set(names))
        if unknown:
            raise ConfigError("~ground_truth_tf: no robot named %s (robots: %s)"
                              % (", ".join(unknown), ", ".join(n or "<empty>" for n in names)))
        return [i for i, n in enumerate(names) if n in set(map(str, setting))]
    if isinstance(setting, str):  # a launch-file string such as "true"/"false"
        setting = setting.strip().lower() in ("true", "1", "yes")
    return list(range(len(names))) if setting else []
