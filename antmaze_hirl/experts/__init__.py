"""Experts that label high-level observations with subgoals."""

from antmaze_hirl.experts.base import Expert
from antmaze_hirl.experts.oracle import PathOracle, plan_subgoal

__all__ = ["Expert", "PathOracle", "plan_subgoal"]
