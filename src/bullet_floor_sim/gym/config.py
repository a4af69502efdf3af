"""The settings of the navigation environment (``FloorNavEnv``) and of its reward."""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Tuple

from ..errors import ConfigError
from ..sim.checks import check_numbers

__all__ = ["NavEnvConfig", "RewardConfig"]


@dataclass(frozen=True)
class RewardConfig:
    """The reward of one step is the sum of these terms, each its weight times a measure
    (a weight of 0 turns its term off):

    Attributes:
        progress: per metre the robot came nearer its goal in the step (straight-line
            distance; moving away costs as much).
        arrival: once, when the robot's centre comes within ``goal_tolerance`` of the goal
            (the episode ends, a success).
        collision: once, when the robot touches a wall (the simulator refused its move) or a
            person's body (the episode ends, a failure).
        intrusion: per second, times how deep (m) the robot's body is inside a person's
            personal space (``personal_space`` beyond the person's body).
        time: per second of the episode.
    """

    progress: float = 1.0
    arrival: float = 10.0
    collision: float = -10.0
    intrusion: float = -1.0
    time: float = -0.1

    def validate(self) -> None:
        check_numbers(self, [f.name for f in fields(self)], "gym reward", least=None)


@dataclass(frozen=True)
class NavEnvConfig:
    """One robot with a goal in a world, among people.

    Attributes:
        world: a world under worlds/, a corpus world, or a path to a user's world.yaml.
        robot: which robot of the world file drives (the others are left out).
        people: how many people walk the world's regions (needs its ROIs when > 0).
        control_rate: actions per second of sim time (the physics runs at
            ``physics_rate``; an action holds for the steps between).
        physics_rate: the simulator's fixed steps per second.
        max_time: sim seconds before an episode is cut off (truncated).
        goal_distance: the straight-line distance (m) from the start to the goal, drawn
            uniformly in this range among the points the robot can reach.
        goal_in_sight: the goal is also in a straight line of sight of the start.
        goal_tolerance: arrival is the robot's centre within this distance (m) of the goal.
        clearance: start and goal keep this much (m) beyond the robot's radius off walls.
        personal_space: how far (m) beyond a person's body the robot intrudes.
        scan_range: ranges are clipped to this (m); no return reads this too.
        ray_threads: threads of the lidar's ray casts (1: a vector env runs one env per
            process, and each would otherwise take every core; 0: all cores).
        reward: the weights of the reward's terms.
    """

    world: str = "office"
    robot: int = 0
    people: int = 5
    control_rate: float = 10.0
    physics_rate: float = 100.0
    max_time: float = 60.0
    goal_distance: Tuple[float, float] = (2.0, 8.0)
    goal_in_sight: bool = False
    goal_tolerance: float = 0.3
    clearance: float = 0.1
    personal_space: float = 0.45
    scan_range: float = 10.0
    ray_threads: int = 1
    reward: RewardConfig = field(default_factory=RewardConfig)

    @property
    def steps_per_action(self) -> int:
        """Physics steps an action holds for."""
        return max(1, int(round(self.physics_rate / self.control_rate)))

    def validate(self) -> None:
        """Raise ConfigError naming the first bad value."""
        check_numbers(self, ("control_rate", "physics_rate", "max_time", "goal_tolerance",
                             "scan_range"), "gym")
        check_numbers(self, ("clearance", "personal_space"), "gym", strict=False)
        try:
            lo, hi = (float(v) for v in self.goal_distance)
        except (TypeError, ValueError):
            raise ConfigError("gym: goal_distance must be (low, high), got %r"
                              % (self.goal_distance,)) from None
        if not 0 < lo <= hi:
            raise ConfigError("gym: goal_distance must be (low, high) with 0 < low <= high, "
                              "got %r" % (self.goal_distance,))
        if not (isinstance(self.people, int) and self.people >= 0):
            raise ConfigError("gym: people must be an integer >= 0, got %r" % (self.people,))
        self.reward.validate()
