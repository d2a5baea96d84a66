"""Dimensional synthesis: path, function and motion generation on any decomposable chain.

The start mechanism's Assur plan is compiled once into a batched evaluator
(:mod:`.evaluator`) whose design variables are every joint coordinate, guide and
tracer point; the optimiser evaluates whole populations × positions in one call.
"""
from .evaluator import DesignSpace, Evaluator, design_space

__all__ = ["DesignSpace", "Evaluator", "design_space"]
