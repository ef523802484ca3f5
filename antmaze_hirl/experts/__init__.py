"""Experts that label high-level observations with subgoals."""

from antmaze_hirl.experts.oracle import PathOracle, plan_subgoal

__all__ = ["PathOracle", "plan_subgoal"]
