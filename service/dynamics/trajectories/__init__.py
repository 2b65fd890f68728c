"""Trajectories: check a sampled motion against the robot's limits (`check`), and time a
geometric path optimally under velocity, acceleration and torque limits, with every limit kept
between the samples too (`retime`). See docs/trajectories.md."""

from service.dynamics.trajectories.check import TrajectoryCheck, check_trajectory
from service.dynamics.trajectories.retiming import Retimed, retime

__all__ = ["Retimed", "TrajectoryCheck", "check_trajectory", "retime"]
