"""Our people messages have the md5sums of the originals (people_msgs, SPENCER).

Each upstream definition is kept as a test fixture (test/fixtures/upstream_msgs, with its
source commit); genmsg computes its md5sum the way ROS does, resolving std_msgs and
geometry_msgs from the installed packages, and it must equal the md5sum of the type this
package generates from msg/. Equal md5sums are what a ROS 1 subscriber checks on connect.
"""
from __future__ import annotations

import os
import subprocess

import pytest

genmsg = pytest.importorskip("genmsg")
from genmsg import gentools, msg_loader  # noqa: E402

FIXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fixtures",
                        "upstream_msgs")


def _msg_dir(package: str) -> str:
    out = subprocess.run(["rospack", "find", package], stdout=subprocess.PIPE, text=True,
                         check=True)
    return os.path.join(out.stdout.strip(), "msg")


def upstream_md5(full_type: str) -> str:
    """The md5sum ROS gives ``full_type`` as defined in the fixtures."""
    search = {"std_msgs": [_msg_dir("std_msgs")], "geometry_msgs": [_msg_dir("geometry_msgs")]}
    for pkg in os.listdir(FIXTURES):
        if os.path.isdir(os.path.join(FIXTURES, pkg)):
            search[pkg] = [os.path.join(FIXTURES, pkg, "msg")]
    ctx = genmsg.MsgContext.create_default()
    spec = msg_loader.load_msg_by_type(ctx, full_type, search)
    msg_loader.load_depends(ctx, spec, search)
    return gentools.compute_md5(ctx, spec)


@pytest.mark.parametrize("ours, upstream", [
    ("People", "people_msgs/People"), ("Person", "people_msgs/Person"),
    ("TrackedPersons", "spencer_tracking_msgs/TrackedPersons"),
    ("TrackedPerson", "spencer_tracking_msgs/TrackedPerson")])
def test_md5sum_equals_the_upstream_definitions(ours, upstream):
    from bullet_floor_sim import msg

    expected = upstream_md5(upstream)
    assert len(expected) == 32
    assert getattr(msg, ours)._md5sum == expected, (ours, upstream)


def test_a_changed_field_changes_the_md5sum(tmp_path):
    # the check can fail: the same computation over an edited copy gives another md5sum
    src = os.path.join(FIXTURES, "people_msgs", "msg", "Person.msg")
    edited = tmp_path / "people_msgs" / "msg"
    edited.mkdir(parents=True)
    (edited / "Person.msg").write_text(open(src).read().replace("float64", "float32"))
    ctx = genmsg.MsgContext.create_default()
    search = {"people_msgs": [str(edited)], "geometry_msgs": [_msg_dir("geometry_msgs")],
              "std_msgs": [_msg_dir("std_msgs")]}
    spec = msg_loader.load_msg_by_type(ctx, "people_msgs/Person", search)
    msg_loader.load_depends(ctx, spec, search)
    assert gentools.compute_md5(ctx, spec) != upstream_md5("people_msgs/Person")
