"""The range checks every config and node parameter set shares (sim/checks.py): one message
naming the owner, the field and the value, for the configs of the core and the nodes alike."""
import re
from dataclasses import dataclass

import numpy as np
import pytest

from bullet_floor_sim.errors import BulletFloorSimError, ConfigError
from bullet_floor_sim.nav.pursuit import FollowerConfig
from bullet_floor_sim.people.crowd.forces import ForceConfig
from bullet_floor_sim.people.follow_config import FollowConfig, FollowError
from bullet_floor_sim.people.prediction.config import PredictionConfig, PredictionError
from bullet_floor_sim.people.tracking.config import TrackerConfig, TrackingError
from bullet_floor_sim.people.walker import WalkerConfig, WalkerError
from bullet_floor_sim.sim.checks import check_integers, check_numbers
from bullet_floor_sim.sim.sensors.odometry import OdometryConfig


@dataclass
class _C:
    a: object = 1.0
    b: object = 2


@pytest.mark.parametrize("value", [0.5, 3, np.float32(0.25), np.int64(7)])
def test_a_finite_number_above_the_bound_passes(value):
    check_numbers(_C(a=value), ("a",), "owner")


@pytest.mark.parametrize("value, strict, least, message", [
    (0.0, True, 0.0, "owner: a must be a finite number > 0, got 0.0"),
    (-0.1, False, 0.0, "owner: a must be a finite number >= 0, got -0.1"),
    (0.5, False, 1.0, "owner: a must be a finite number >= 1, got 0.5"),
    (float("nan"), False, None, "owner: a must be a finite number, got nan"),
    (float("inf"), True, 0.0, "owner: a must be a finite number > 0, got inf"),
    (True, True, 0.0, "owner: a must be a finite number > 0, got True"),
    ("1", True, 0.0, "owner: a must be a finite number > 0, got '1'"),
    (None, True, 0.0, "owner: a must be a finite number > 0, got None")])
def test_anything_else_is_one_error_naming_owner_field_bound_and_value(value, strict, least, message):
    with pytest.raises(ConfigError, match="^%s$" % re.escape(message)):
        check_numbers(_C(a=value), ("b", "a"), "owner", least=least, strict=strict)


def test_the_zero_the_bound_allows_passes_and_the_first_bad_field_is_named():
    check_numbers(_C(a=0.0), ("a",), "owner", strict=False)
    check_numbers(_C(a=-5.0), ("a",), "owner", least=None)
    with pytest.raises(ConfigError, match=r"^o: b must"):
        check_numbers(_C(a=-1.0, b=-1.0), ("b", "a"), "o")


def test_prefix_unit_and_error_class_go_into_the_message():
    with pytest.raises(FollowError, match=r"^node: ~a must be a finite number of seconds > 0, "
                                          r"got -1\.0$"):
        check_numbers(_C(a=-1.0), ("a",), "node", error=FollowError, prefix="~", unit="seconds")


@pytest.mark.parametrize("value, ok", [(1, True), (np.int32(4), True), (0, False), (2.0, False),
                                       (True, False), (None, False)])
def test_integers_refuse_floats_bools_and_values_below_the_bound(value, ok):
    if ok:
        check_integers(_C(b=value), ("b",), "owner")
        return
    with pytest.raises(ConfigError, match=r"^owner: b must be an integer >= 1, got %s$"
                                          % re.escape(repr(value))):
        check_integers(_C(b=value), ("b",), "owner")


@pytest.mark.parametrize("config, error, message", [
    (FollowConfig(trail=-1.0), FollowError, "follower: trail must be a finite number >= 0"),
    (FollowConfig(search_rounds=0), FollowError, "follower: search_rounds must be an integer >= 1"),
    (PredictionConfig(temperature=0.5), PredictionError,
     "prediction: temperature must be a finite number >= 1"),
    (TrackerConfig(gate=0.0), TrackingError, "tracker: gate must be a finite number > 0"),
    (WalkerConfig(goal_timeout=0.0), WalkerError,
     "walker: goal_timeout must be a finite number of seconds > 0"),
    (FollowerConfig(max_linear=float("nan")), BulletFloorSimError,
     "path follower: max_linear must be a finite number > 0, got nan")])
def test_the_configs_of_the_core_share_the_message(config, error, message):
    with pytest.raises(error, match="^" + re.escape(message)):
        config.check()


@pytest.mark.parametrize("config, message", [
    (OdometryConfig(noise_rot=-0.1), "w: noise_rot must be a finite number >= 0, got -0.1"),
    (ForceConfig(tau=0.0), "w: tau must be a finite number > 0, got 0.0"),
    (ForceConfig(horizon=float("nan")), "w: horizon must be a finite number >= 0, got nan")])
def test_the_world_files_sections_share_it_too(config, message):
    with pytest.raises(ConfigError, match="^" + re.escape(message) + "$"):
        config.validate("w")
