"""multiloop: structural analysis, decomposition, kinematics, forces and atlases of
planar multi-loop linkages with multiple joints.

The library lives in three packages (dependencies point one way):
``topo`` (graph and structure, no solving) ← ``kin`` (solvers, forces, screws, plots)
← ``catalogue`` (named mechanisms, synthesis, atlases).  This package holds only the
command-line interface, which wires them together.
"""
__version__ = "0.1.0"
