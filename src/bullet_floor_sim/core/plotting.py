"""matplotlib for the PNG writers (headless Agg backend), with a one-line error when missing."""
from __future__ import annotations

from typing import Any

from .errors import BulletFloorSimError

__all__ = ["pyplot"]


def pyplot(what: str) -> Any:
    """``matplotlib.pyplot`` on the Agg backend.

    Args:
        what: the option or command that needs it, for the error (e.g. ``--plot``).

    Raises:
        BulletFloorSimError: matplotlib is not installed.
    """
    try:
        import matplotlib
    except ImportError:
        raise BulletFloorSimError("%s needs matplotlib, which is not installed "
                                  "(apt install python3-matplotlib)" % what) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt
