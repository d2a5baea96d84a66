"""Compiled plans: a mechanism's solving plan lowered to flat arrays and run by one
compiled kernel over a whole batch of positions.

:func:`kernel_plan` lowers a :class:`~kin.solve.SolvePlan` once: each compiled step
gives its :class:`~kin.groups.step.Lowered` numbers (its kind's code in
:data:`kin.groups.registry.COMPILED`, link indices, lengths, signs, reference
directions).  :func:`run_positions` then runs one numba kernel (``kin._kernel_nb``)
that takes the steps in order and, for each, calls the scalar closed form of its kind
once, looping over all the positions: the five dyads (Vasechkin et al. 2017 [1]_, eqs.
(1)-(3), (9)-(11), (15)-(18), (23)-(25), (30)-(32)), the two drivers and the actuated
triangle.  Each does the NumPy kernel's operations in the same order (the floats agree
to rounding) and gives the same statuses.  The drivers' cos and sin are NumPy's own,
computed before the loop; the angle rows are fdlibm's ``atan2`` (Sun Microsystems 1993,
within 1 ulp of NumPy's) in the kernel when every step is solved, else NumPy's, later.
:func:`run_designs` runs the same steps for a batch of D designs: synthesis's populations
and polish (:func:`compiled_batches`).  Their numbers come from each kind's compiled
lowering (:func:`lower_designs`: the adapter's ``compiled_lower``, the floats its
:meth:`~kin.groups.step.GroupStep.lower` gives, bit for bit, ``tests/test_design_batch.py``)
in one call, no step bound in Python; a kind without one is bound and lowered by its
adapter (:func:`design_floats`).  The NumPy path stays as the oracle
(``tests/test_kernels.py``, ``tests/test_synthesis_kernel.py``) and solves what the
kernel does not: a plan with a Newton group, the probes of the continuation walk,
velocities and accelerations, and the reasons of the rows that fail.  A triad's and a
class IV group's compiled steps follow their mode along each design's inputs
(:func:`kin.groups._triad_nb.triad_place`, ``class4_place``: Hunt 1983's modes, the NumPy
tracker's steps, modes and statuses): they serve batches of designs only (*tracked*
steps, :meth:`KernelPlan.covers`), since ``solve``'s kernel routes solve a failed row
again on its own; in ``solve`` their trackers run the all-modes phases compiled
(:mod:`kin.groups._triad_nb`) in the same modes as the plan kernel
(:func:`kin.kernel_mode.chooses`).

Why numba: it is the JIT that pylinkage uses (the peer we measure against), it ships
wheels for Linux, macOS and Windows, and it caches compiled code on disk
(``cache=True``), so a process after the first loads the kernel instead of compiling it.

When: in a fresh process, importing numba and reading the cached kernel cost about
1.5 s of CPU, most of it numba's own start-up (``benchmarks/bench_solve.py`` prints
both).  That is more than one batch saves: the kernel saves well under a microsecond
per position.  The
kernel agrees with the NumPy path to rounding (a few units in the last place), not
bit for bit, so it is opt-in: with ``MULTILOOP_KERNEL=off`` (the default) every result
is the NumPy path's, whatever the process loaded before, so the command line, the
library and the web page give the same bits for the same input.  ``on`` always uses
the kernel (if numba is installed); ``auto`` uses it once it is loaded in the process
(:func:`load`) and loads it itself for a batch of at least :data:`LAZY_MIN` positions.
:func:`using` sets the mode for a block, in its own thread (the other threads
keep theirs).  The command line's batches never import
numba, so its cold start does not grow.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical model
   of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2) (2017) 73-79.
   doi:10.20914/2310-1202-2017-2-73-79.
"""
from __future__ import annotations

import contextlib
import functools
import math
import threading
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .geometry import joint_rows
from .groups.registry import COMPILED, LOWERING
from .groups.step import trig_row
from .kernel_mode import LAZY_MIN, MODES, chooses, is_default, is_loaded, mode, turn_off, using
from .memo import cached

__all__ = ["KernelPlan", "KernelRun", "kernel_plan", "lower_plan", "run_positions", "run_motion",
           "design_floats", "lower_designs", "run_designs", "design_work", "compiled_batches",
           "for_batches", "load", "is_loaded", "wanted",
           "mode", "using", "MODES", "LAZY_MIN"]

_CODES = {key: i for i, key in enumerate(COMPILED)}


@dataclass(frozen=True, eq=False)
class KernelPlan:
    """A plan lowered to flat arrays (read-only): ``codes`` (n_steps,) the kind of each
    step (its index in the registry; -1: no compiled step), ``ints`` / ``floats``
    (n_steps, width) each step's numbers, ``unknown`` (n_steps, width) the links each
    step places (-1 padded), ``frame`` the frame's link index, ``trig`` (K, 2) the
    (driver, ±1) whose cos and sin of ``±input`` the steps read from the table ``W``,
    ``hosts`` / ``offs`` the link carrying each joint and tracer point and the point's
    offset from that link's reference point, ``complete`` whether every step has a
    compiled step, ``lowers`` (n_steps,) whether its adapter has a compiled lowering
    for batches of designs (:data:`~kin.groups.registry.LOWERING`) and ``rows``
    (n_steps, width) the joint rows and links that lowering reads
    (:meth:`~kin.groups.step.GroupStep.lower_indices`; rows of
    :meth:`~kin.geometry.Geometry.gather`'s tables), ``tracked`` (n_steps,) whether its
    compiled step follows a mode along the inputs (:attr:`~kin.groups.step.GroupStep.tracked`:
    batches of designs only, ``complete`` then False)."""

    codes: np.ndarray
    ints: np.ndarray
    floats: np.ndarray
    unknown: np.ndarray
    frame: int
    trig: np.ndarray | None = None
    hosts: np.ndarray | None = None
    offs: np.ndarray | None = None
    lowers: np.ndarray | None = None
    rows: np.ndarray | None = None
    tracked: np.ndarray | None = None

    def covers(self, steps, tracked: bool = False) -> bool:
        """Whether every step of ``steps`` has a compiled step, a tracked one only with
        ``tracked`` (a batch of designs, each solved along its own inputs: ``solve``'s
        routes solve a failed row again on its own, which a followed mode does not allow)."""
        return _every(*(self._batch_steps if tracked else self._solve_steps), steps)

    def lowered(self, steps) -> bool:
        """Whether every step of ``steps`` has a compiled lowering for batches of designs
        (:func:`lower_designs`)."""
        return _every(*self._lowered_steps, steps)

    @property
    def complete(self) -> bool:
        """Whether ``solve``'s kernels run every step (each compiled, none tracked)."""
        return self._solve_steps[1]

    @functools.cached_property
    def _solve_steps(self) -> tuple[np.ndarray, bool]:
        """The steps ``solve``'s kernels run (compiled, not tracked), and whether all are."""
        return _with_all((self.codes >= 0) & ~self.tracked)

    @functools.cached_property
    def _batch_steps(self) -> tuple[np.ndarray, bool]:
        """The steps a batch of designs runs compiled, and whether all are."""
        return _with_all(self.codes >= 0)

    @functools.cached_property
    def _lowered_steps(self) -> tuple[np.ndarray, bool]:
        """The steps with a compiled lowering, and whether all have one."""
        return _with_all(self.lowers)


def _with_all(mask: np.ndarray) -> tuple[np.ndarray, bool]:
    mask.flags.writeable = False
    return mask, bool(mask.all())


def _every(mask: np.ndarray, whole: bool, steps) -> bool:
    """Whether ``mask`` holds at every step of ``steps`` (``whole``: at every step)."""
    if len(steps) == len(mask):
        return whole
    return bool(np.all(mask[np.asarray(list(steps), int)]))


def _table(rows, dtype, fill) -> np.ndarray:
    width = max((len(r) for r in rows), default=0) or 1
    out = np.full((len(rows), width), fill, dtype)
    for i, r in enumerate(rows):
        out[i, :len(r)] = r
    out.flags.writeable = False
    return out


def lower_plan(sp) -> KernelPlan:
    """Lower the compiled plan ``sp`` (:class:`~kin.solve.SolvePlan`) to flat arrays."""
    low = [st.closed.lower(sp.origins) if st.closed is not None else None for st in sp.steps]
    codes = np.array([_CODES.get(lw.key, -1) if lw is not None else -1 for lw in low], np.int64)
    codes.flags.writeable = False
    lowers = np.array([lw is not None and _lowers(st.closed, lw.key) for st, lw in zip(sp.steps, low)], bool)
    lowers.flags.writeable = False
    row = joint_rows(sp.mechanism).__getitem__
    rows = _table([st.closed.lower_indices(row) if ok else () for st, ok in zip(sp.steps, lowers)], np.int64, -1)
    trig = np.array(sorted({(d, 1 if sign > 0 else -1) for lw in low if lw is not None for d, sign in lw.trig}),
                    np.int64).reshape(-1, 2)
    trig.flags.writeable = False
    tracked = np.array([lw is not None and bool(st.closed.tracked) for st, lw in zip(sp.steps, low)], bool)
    tracked.flags.writeable = False
    return KernelPlan(codes, _table([lw.ints if lw else () for lw in low], np.int64, -1),
                      _table([lw.floats if lw else () for lw in low], float, np.nan),
                      _table([st.unknown for st in sp.steps], np.int64, -1),
                      sp.mechanism.link_names.index(sp.mechanism.frame), trig, *_hosts(sp), lowers, rows, tracked)


def _hosts(sp) -> tuple[np.ndarray, np.ndarray]:
    """Host link and offset of every joint, then every tracer point (``SolvePlan``)."""
    m = sp.mechanism
    hosts = np.array([*sp.joint_host, *sp.point_host], np.int64)
    at = np.array([*(j.at for j in m.joints), *(p.at for p in m.points)], float).reshape(-1, 2)
    offs = at - np.asarray(sp.origins, float)[hosts]
    hosts.flags.writeable = offs.flags.writeable = False
    return hosts, offs


def kernel_plan(sp) -> KernelPlan:
    """The lowered plan of ``sp``, kept on it (lowered on first use).

    Examples
    --------
    >>> from multiloop.kin.solve import plan_of
    >>> from multiloop.topo.model import MechanismBuilder
    >>> b = MechanismBuilder()
    >>> b.add_link("ground", frame=True)
    >>> for n, lk, at in [("O", ("ground", "crank"), (0, 0)), ("A", ("crank", "rod"), (1, 0)),
    ...                   ("B", ("rod", "rocker"), (3, 2)), ("C", ("rocker", "ground"), (4, 0))]:
    ...     b.add_joint(n, "R", lk, at=at)
    >>> b.add_driver("O")
    >>> kp = kernel_plan(plan_of(b.build()))
    >>> [list(COMPILED)[c] for c in kp.codes], kp.complete
    (['drive_R', <GroupKind.RRR: 'RRR'>], True)
    """
    return cached(sp, "kernel", lambda sp, _: lower_plan(sp))


def load():
    """Import numba and the kernel (compiled on first use, then read from the disk
    cache); None when numba is not installed."""
    if _LOADED:
        return _LOADED[0]
    try:
        from . import _kernel_nb
    except ImportError:
        return None
    except RuntimeError as e:               # numba found no writable cache directory
        warnings.warn(f"compiled plans unavailable, the NumPy path solves: {e}", RuntimeWarning, stacklevel=2)
        turn_off()
        return None
    _LOADED.append(_kernel_nb)
    return _kernel_nb


_LOADED: list = []


def wanted(n_positions: int) -> bool:
    """Whether a batch of ``n_positions`` is solved by the kernel in the current mode."""
    return chooses(n_positions) and load() is not None


def compiled_batches() -> bool:
    """Whether populations of designs (synthesis's objective, :mod:`kin.design`) run
    compiled: in the modes ``on`` and ``auto``, and by default (``MULTILOOP_KERNEL``
    unset) whenever numba is installed: a search evaluates thousands of candidates, so
    numba's start-up pays for itself, and the search's result does not depend on what
    else the process ran.  Never in an explicit ``off``."""
    if mode() == "off" and not is_default():
        return False
    return load() is not None


def for_batches():
    """A context in which design batches run compiled when :func:`compiled_batches`
    says so (``using("on")``), else as they are: synthesis's populations and the curve
    atlas's screens."""
    return using("on") if compiled_batches() else contextlib.nullcontext()


_ONES: dict = {}


def _factors(n_steps: int, M: int, signs: dict) -> np.ndarray:
    """Each step's branch factor: (n_steps, 1), or (n_steps, M) when one varies by row."""
    if not signs:
        hit = _ONES.get(n_steps)
        if hit is None:
            hit = _ONES[n_steps] = np.ones((n_steps, 1))    # (writable: one compiled signature)
        return hit
    per_row = any(np.ndim(v) for v in signs.values())
    F = np.ones((n_steps, M if per_row else 1))
    for k, v in signs.items():
        F[k] = v
    return F


#: work arrays kept per thread between calls (fresh pages cost more than the kernel on a
#: large batch), up to this many floats each
SCRATCH_MAX = 1 << 22
_SCRATCH = threading.local()


def _scratch(name: str, shape: tuple) -> np.ndarray:
    """A work array of ``shape`` (contents undefined) reused by this thread's later calls."""
    n = math.prod(shape)                 # (np.prod costs ten times as much on a tuple)
    if n > SCRATCH_MAX:
        return np.empty(shape)
    buf = getattr(_SCRATCH, name, None)
    if buf is None or buf.size < n:
        buf = np.empty(n)
        setattr(_SCRATCH, name, buf)
    return buf[:n].reshape(shape)


def design_work(name: str, shape: tuple) -> np.ndarray:
    """A work array of a batch of designs whose poses the caller reads at once
    (:func:`kin.design.solve_designs` with ``reuse``: a population's objective), reused
    by this thread's next such batch.  A population's pose store is about a megabyte:
    allocated afresh at every call, glibc maps it from the system and the first writes
    fault every page (half the global search's time in a process whose allocation
    history had kept glibc's adaptive mmap threshold low)."""
    return _scratch("design " + name, shape)


def _trig(kp: KernelPlan, X: np.ndarray) -> np.ndarray:
    """The table ``W`` (4 n_drivers, M): cos and sin of ±input (the rows asked for), in
    this thread's work array (it lives only during the kernel's call)."""
    W = _scratch("W", (4 * X.shape[1] if len(kp.trig) else 0, X.shape[0]))
    for d, sign in kp.trig.tolist():
        r = trig_row(d, sign)
        th = X[:, d] if sign > 0 else -X[:, d]
        np.cos(th, out=W[r])
        np.sin(th, out=W[r + 1])
    return W


def _steps(kp: KernelPlan, steps) -> np.ndarray:
    """The steps to run as an array (every step's cached)."""
    n = len(kp.codes)
    if len(steps) == n:
        hit = _ALL.get(n)
        if hit is None:
            hit = _ALL[n] = np.arange(n, dtype=np.int64)
        return hit
    return np.asarray(list(steps), np.int64)


_ALL: dict = {}


def every_step(kp: KernelPlan) -> np.ndarray:
    """Every step of ``kp`` as the array the kernels run (read-only, shared)."""
    return _steps(kp, range(len(kp.codes)))


def run_motion(kp: KernelPlan, X: np.ndarray, T: np.ndarray, P: np.ndarray, fail: np.ndarray,
               pend: np.ndarray, want_links: np.ndarray, want_points: np.ndarray) -> int:
    """Every step at the inputs ``X`` (M, n_drivers, C-contiguous, writable) on the
    reference branch in one compiled call (:func:`kin._kernel_nb.solve_motion`): the
    poses into ``T`` (n_links, 3, M), the joints' and tracer points' positions into ``P``
    (n_points, 2, M), each row's first failing status into ``fail`` (M,) int8 zeros,
    1 into ``pend`` (n_links,) int8 zeros for the links whose angle rows were derived
    from their cos and sin; only the derived angles of ``want_links`` and the points of
    ``want_points`` (int8 masks) are computed, the others NaN.  Returns the number of
    failed rows, or -1 when an input is not finite (nothing solved).  The work rows (cos
    and sin tables) are this thread's scratch arrays (:func:`_scratch`).  The lean route
    of :func:`kin.solve.solve` for a whole motion; :func:`run_positions` serves every
    other caller."""
    W, C, S = _motion_work(X.shape[1], T.shape[0], X.shape[0])
    return load().solve_motion(kp.codes, kp.ints, kp.floats, kp.unknown, kp.trig, kp.frame, X, W, C, S,
                               T, fail, pend, want_links, kp.hosts, kp.offs, want_points, P)


def _motion_work(n_drivers: int, n_links: int, M: int) -> tuple:
    """:func:`run_motion`'s three work arrays (this thread's scratch), looked up once for
    a run of small calls of the same shape (a loop of solves of one batch size, where
    the lookups cost a third of the kernel's own time); a large batch looks them up each
    time (no view kept of a buffer that a larger batch has since replaced)."""
    key = (n_drivers, n_links, M)
    hit = getattr(_SCRATCH, "motion", None)
    if hit is not None and hit[0] == key:
        return hit[1]
    work = (_scratch("W", (4 * n_drivers, M)), _scratch("C", (n_links, M)), _scratch("S", (n_links, M)))
    if max(4 * n_drivers, n_links) * M <= SMALL_BATCH:
        _SCRATCH.motion = (key, work)
    return work


#: the largest work array (floats) whose views :func:`_motion_work` keeps between calls
SMALL_BATCH = 1 << 16


class KernelRun(NamedTuple):
    """What :func:`run_positions` gives: the cos and sin rows ``C``, ``S`` (n_links, M),
    ``fail`` (M,) int8 the status of each position's first failing step, ``failed`` the
    number of such positions, ``pend`` (n_links,) 1 for the links whose angle rows were
    derived from their cos and sin (``arctan2``, in the kernel), and ``points`` the
    positions (M, n_joints + n_points, 2) of the joints and tracer points (or None)."""

    C: np.ndarray
    S: np.ndarray
    fail: np.ndarray
    failed: int
    pend: np.ndarray
    points: np.ndarray | None

    @property
    def derived(self) -> np.ndarray:
        return np.flatnonzero(self.pend)


def run_positions(kp: KernelPlan, X: np.ndarray, steps, signs: dict, T: np.ndarray,
                  points: bool = False, scratch: bool = False) -> KernelRun:
    """Run the kernel on the steps ``steps`` at the inputs ``X`` (M, n_drivers) with the
    branch factors ``signs`` {step: factor or (M,) factors}; the poses go into ``T``
    (n_links, 3, M).  With ``points`` (every step solved) the joints and tracer points
    too.  With ``scratch`` the cos and sin rows ``C``, ``S`` are this thread's work
    arrays: valid only until its next call (for a caller that needs only ``T`` and the
    points)."""
    nb = load()
    X = np.ascontiguousarray(X, float)
    if not X.flags.writeable:              # one compiled signature (numba types read-only arrays apart)
        X = X.copy()
    M = X.shape[0]
    nl = T.shape[0]
    C, S = (_scratch("C", (nl, M)), _scratch("S", (nl, M))) if scratch else (np.empty((nl, M)), np.empty((nl, M)))
    C[kp.frame], S[kp.frame] = 1.0, 0.0
    fail = np.zeros(M, np.int8)
    pend = np.zeros(nl, np.int8)
    hosts = kp.hosts if points else kp.hosts[:0]
    P = np.empty((hosts.size, 2, M))
    failed = nb.solve_positions(kp.codes, kp.ints, kp.floats, kp.unknown, _steps(kp, steps), X, _trig(kp, X),
                                _factors(len(kp.codes), M, signs), T, C, S, fail, pend, hosts, kp.offs, P)
    return KernelRun(C, S, fail, failed, pend, P.transpose(2, 0, 1) if points else None)


def design_floats(kp: KernelPlan, bound, steps, origins: np.ndarray, D: int) -> np.ndarray:
    """The numbers of D designs for the steps ``steps`` of ``kp``: ``(D, n_steps,
    width)``, each step ``bound[i]`` (bound to the designs' geometry, :mod:`kin.design`)
    lowered with the designs' link reference points ``origins`` (n_links, D, 1, 2)
    (:meth:`~kin.groups.step.GroupStep.lower` gives arrays ``(D, 1)`` where a number
    varies by design); the codes, link indices and trig rows are the plan's own."""
    out = np.full((D, len(kp.codes), kp.floats.shape[1]), np.nan)
    for k, step in zip(steps, bound):
        row = out[:, k]
        for i, v in enumerate(step.lower(origins).floats):
            row[:, i] = v.ravel() if isinstance(v, np.ndarray) and v.ndim else v
    return out


def _lowers(step, key) -> bool:
    """Whether plan step ``step`` (lowered under ``key``) has the registry's compiled
    lowering of ``key`` and lowers as the class that declares it (a subclass with its own
    :meth:`~kin.groups.step.GroupStep.lower` is bound and lowered in NumPy)."""
    fn = getattr(step, "compiled_lower", None)
    if fn is None or LOWERING.get(key) is not fn:
        return False
    owner = type(step) if "compiled_lower" in vars(step) else \
        next(k for k in type(step).__mro__ if "compiled_lower" in vars(k))
    return type(step).lower is owner.lower


def lower_designs(sp, kp: KernelPlan, geo, steps) -> np.ndarray:
    """The numbers of the designs of ``geo`` (:class:`~kin.geometry.Geometry` of a batch)
    for the steps ``steps`` (every one with a compiled lowering,
    :meth:`KernelPlan.lowered`): what :func:`design_floats` gives from the bound
    steps, by one compiled call on the joints' table (:meth:`~kin.geometry.Geometry.gather`)."""
    P, U, O = geo.gather(sp)
    out = np.full((geo.D, len(kp.codes), kp.floats.shape[1]), np.nan)
    load().lower_designs(kp.codes, kp.rows, _steps(kp, steps), P, U, O, float(sp.size), out)
    return out


def run_designs(kp: KernelPlan, floats: np.ndarray, X: np.ndarray, steps, T: np.ndarray, scratch: bool = False):
    """Run the plan's steps ``steps`` for D designs (``floats`` from
    :func:`lower_designs`) at the inputs ``X`` (D, N, n_drivers) in one compiled call
    (:func:`kin._kernel_nb.solve_designs`): the poses into the store ``T`` (n_links, 3,
    D, N).  Returns the cos and sin rows ``C``, ``S`` (n_links, D, N) and the links
    whose angle rows are still to be derived from them; with ``scratch`` ``C`` and ``S``
    are this thread's work arrays (:func:`design_work`)."""
    nl, D, N = T.shape[0], floats.shape[0], X.shape[1]
    X = np.ascontiguousarray(X, float)
    if not X.flags.writeable:
        X = X.copy()
    C, S = (design_work("C", (nl, D, N)), design_work("S", (nl, D, N))) if scratch else \
        (np.empty((nl, D, N)), np.empty((nl, D, N)))
    pend = np.zeros(nl, np.int8)
    load().solve_designs(kp.codes, kp.ints, floats, kp.unknown, _steps(kp, steps), kp.trig, kp.frame, X,
                         _scratch("W", (4 * X.shape[2], N)), _scratch("Td", (nl, 3, N)), _scratch("C", (nl, N)),
                         _scratch("S", (nl, N)), np.zeros(N, np.int8), pend, T, C, S)
    return C, S, np.flatnonzero(pend)
