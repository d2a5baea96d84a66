"""Dimensional synthesis: path, function and motion generation on any decomposable chain.

The start mechanism's Assur plan is compiled once into a batched evaluator
(:mod:`.evaluator`) whose design variables are every joint coordinate, guide and
tracer point; the optimiser (:mod:`.optimise`) scores whole populations ×
positions in one call; :func:`synthesise` is the entry point, and :mod:`.budget` holds
the run's limits (evaluations, reproducible; seconds, a cap).
"""
from .budget import Budget
from .evaluator import DesignSpace, Evaluator, design_space
from .objective import Constraints, Problem, transmission_angles
from .synthesise import SynthesisResult, function_target, motion_target, path_target, synthesise
from .closedform import (burmester_four_bar, burmester_points, centre_point, circle_point_curve, freudenstein,
                         freudenstein_four_bar, pose_positions)
from .targets import FunctionTarget, MotionTarget, PathTarget, read_table

__all__ = ["Budget", "DesignSpace", "Evaluator", "design_space", "Constraints", "Problem", "transmission_angles",
           "SynthesisResult", "synthesise", "path_target", "function_target", "motion_target",
           "PathTarget", "FunctionTarget", "MotionTarget", "read_table",
           "freudenstein", "freudenstein_four_bar", "burmester_four_bar", "burmester_points", "centre_point",
           "circle_point_curve", "pose_positions"]
