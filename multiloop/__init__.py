"""multiloop: structural analysis, decomposition, kinematics, forces and atlases of
planar multi-loop linkages with multiple joints.

The library lives in three packages (dependencies point one way):
``topo`` (graph and structure, no solving) ← ``kin`` (solvers, forces, screws, plots)
← ``catalogue`` (named mechanisms, synthesis, atlases).  This package holds the
command-line interface, the exchange formats and the Python façade below, which
wires them together (``import multiloop as ml``; docs/api.md).  Each function
imports its module when first called, so ``import multiloop`` stays fast.

Examples
--------
>>> import multiloop as ml
>>> m = ml.load("four_bar")
>>> ml.analyse(m).F
1
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["load", "analyse", "decompose", "solve", "forces", "check", "synthesise", "atlas",
           "__version__"]


def load(source):
    """A :class:`~multiloop.topo.model.Mechanism` from a file or a catalogue name.

    Parameters
    ----------
    source : str or path
        A ``.toml``/``.json`` mechanism file, a Pyslvs project (``.pyslvs``) or bare
        expression (``.expr``), or the name of a bundled mechanism
        (``multiloop catalogue`` lists them).
    """
    from multiloop.inputs import load_mechanism  # noqa: PLC0415
    return load_mechanism(source)


def _mechanism(m):
    return m if hasattr(m, "joints") and hasattr(m, "links") else load(m)


def analyse(mechanism, **kwargs):
    """The structural report (Pozhbelko & Kuts 2020 numbers) of a mechanism or chain.

    Returns :class:`~multiloop.topo.numbers.StructuralReport` (``as_dict()`` is the
    JSON of ``multiloop analyse --json``).  ``mechanism`` may be a file or name.
    """
    from multiloop.topo.numbers import structural_report  # noqa: PLC0415
    return structural_report(_mechanism(mechanism), **kwargs)


def decompose(mechanism, **kwargs):
    """The Assur groups in solving order (:class:`~multiloop.topo.assur.AssurPlan`)."""
    from multiloop.topo.assur import decompose as _decompose  # noqa: PLC0415
    return _decompose(_mechanism(mechanism), **kwargs)


def solve(mechanism, inputs, *, designs=None, names=None, **kwargs):
    """Positions (and with ``derivatives=True`` velocities, accelerations).

    ``inputs`` are driver values from the reference configuration: rad for an R
    driver, m for a P driver; a scalar, shape (N,) or (N, n_drivers).  Returns
    :class:`~multiloop.kin.state.KinematicState` (NumPy arrays per joint and link);
    ``outputs=[names]`` computes only those joints, points and links.

    With ``designs`` (D, p), D designs of the mechanism's topology are solved in one pass
    (:func:`multiloop.kin.design.solve_designs`; columns named by ``names``, default
    :func:`multiloop.kin.geometry.design_names` of the mechanism and its tracer points),
    and the result is a :class:`~multiloop.kin.design.DesignPoses` of shape (D, N).
    """
    m = _mechanism(mechanism)
    if designs is not None:
        from multiloop.kin.design import design_names, solve_designs  # noqa: PLC0415
        names = design_names(m, [p.name for p in m.points]) if names is None else names
        return solve_designs(m, names, designs, inputs, **kwargs)
    from multiloop.kin.solve import solve as _solve  # noqa: PLC0415
    return _solve(m, inputs, **kwargs)


def forces(mechanism, state_or_inputs, **kwargs):
    """Kinetostatics: reactions and balancing moments (:class:`~multiloop.kin.forces.ForceResult`).

    ``state_or_inputs`` is a :class:`KinematicState` or driver values (rad or m).
    """
    from multiloop.kin.forces import forces as _forces  # noqa: PLC0415
    return _forces(_mechanism(mechanism), state_or_inputs, **kwargs)


def check(mechanism, **kwargs):
    """The design check over the whole motion (:class:`~multiloop.kin.check.CheckReport`)."""
    from multiloop.kin.check import check as _check  # noqa: PLC0415
    return _check(_mechanism(mechanism), **kwargs)


def synthesise(start=None, **kwargs):
    """Dimensional synthesis from a start mechanism (path, function or motion targets),
    returning :class:`~multiloop.catalogue.dimensional.SynthesisResult`; without a
    start, path synthesis in which the atlas chooses the topology
    (``synthesise(path=..., links=(4, 6, 8), top=3, evaluations=100_000)``; ``atlas=`` an
    atlas with coupler curves, default the default atlas built into the user cache on
    first use), returning :class:`~multiloop.catalogue.topology_synthesis.TopologySynthesis`.
    """
    if start is None:
        from multiloop.catalogue.topology_synthesis import synthesise as _topo  # noqa: PLC0415
        return _topo(**kwargs)
    from multiloop.catalogue.dimensional import synthesise as _synthesise  # noqa: PLC0415
    return _synthesise(_mechanism(start), **kwargs)


def atlas(links: int, dof: int = 1, *, loops: bool = True, workers: int | None = 1, **options):
    """Every non-isomorphic, non-degenerate chain of ``links`` links and ``dof`` DOF.

    ``options`` are those of :class:`~multiloop.catalogue.synthesis.SynthesisOptions`
    (``simple_joints``, ``planar``, ...).  Returns a list of
    :class:`~multiloop.catalogue.synthesis.ChainRecord` sorted by canonical form.
    """
    from multiloop.catalogue.distributed import type_synthesis  # noqa: PLC0415
    from multiloop.catalogue.synthesis import SynthesisOptions  # noqa: PLC0415
    return type_synthesis(SynthesisOptions(links, dof, **options), loops=loops, workers=workers)
