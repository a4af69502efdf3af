"""Where this package's data (urdf/, worlds/) lives, in a source checkout or an install."""
from __future__ import annotations

import functools
import os

__all__ = ["package_root", "worlds_dir", "corpus_dir", "corpus_worlds"]


@functools.lru_cache(maxsize=None)
def package_root() -> str:
    """Absolute path of the bullet_floor_sim package directory (the one with package.xml).

    Looks beside the sources first (src/bullet_floor_sim -> repo root), then asks rospkg
    (installed layouts, share/bullet_floor_sim).

    Raises:
        RuntimeError: the package cannot be found.
    """
    here = os.path.dirname(os.path.abspath(__file__))
    src_root = os.path.normpath(os.path.join(here, "..", ".."))
    if os.path.isfile(os.path.join(src_root, "package.xml")):
        return src_root
    try:
        import rospkg  # ROS tooling, not rospy: finds installed packages

        return rospkg.RosPack().get_path("bullet_floor_sim")
    except Exception as e:  # rospkg missing or package not on ROS_PACKAGE_PATH
        raise RuntimeError("bullet_floor_sim: cannot find the package directory (%s); source "
                           "your workspace's setup.bash" % e) from None


def worlds_dir() -> str:
    """The package's worlds/ directory."""
    return os.path.join(package_root(), "worlds")


def corpus_dir() -> str:
    """Where tools/corpus.py builds the corpus of real buildings: $BFS_CORPUS, else
    $XDG_CACHE_HOME (~/.cache)/bullet_floor_sim/corpus."""
    return os.environ.get("BFS_CORPUS") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"),
        "bullet_floor_sim", "corpus")


def corpus_worlds() -> list:
    """The world.yaml paths of the corpus buildings built so far (sorted by name)."""
    d = corpus_dir()
    if not os.path.isdir(d):
        return []
    return [os.path.join(d, n, "world.yaml") for n in sorted(os.listdir(d))
            if os.path.isfile(os.path.join(d, n, "world.yaml"))]
