"""Global search (differential evolution or CMA-ES) and the local polish.

``"local"`` is no global search at all: the start design goes straight to the
polish (a start already near a solution, e.g. one retrieved from a curve atlas).

Both global methods see the design in the unit box and score whole populations
in one call of :meth:`~.objective.Problem.batch`:

* ``"de"``: differential evolution (Storn & Price 1997), SciPy's default settings
  with deferred updating, vectorised over the population (:func:`_de`: one call per
  generation);
* ``"cmaes"``: the ``cma`` package's CMA-ES (Hansen & Ostermeier 2001), one
  ``ask``/``tell`` per generation.

Both stop when the run's :class:`~.budget.Meter` says so (its evaluations or its
seconds are spent) or when the best objective reaches the tolerance.  Under an
evaluation budget every decision (the probes' schedule, the stop) reads the count of
evaluations, not the clock, so a seed gives the same search on any machine.
The polish is :func:`scipy.optimize.least_squares` (trust-region reflective) on
the design plus one driver value per target, with the problem's exact Jacobian where
it has one (``exact_jacobian``: the poses' design sensitivities,
:mod:`multiloop.kin.sensitivity`), else the forward-difference Jacobian computed as
one batched call (all perturbed designs together).  :func:`polish_batch` runs the
same trust region (SciPy's ``trf`` iteration, ported to act on K designs at once) for
several designs together, each residual and Jacobian call one batch over the compiled
plan, each iteration's proposal and verdict one compiled call (``_trust_nb``): synthesis polishes its
probes' designs and its final candidates so, one or several.  When the
problem has constraints, the polish's residual vector carries the same weighted
violation as the global objective (:meth:`~.objective.Problem.penalty_batch`) as one
more residual, so the polish trades the targets against the constraints as the
search does instead of polishing a design out of them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .budget import Budget, Meter
from .objective import Problem, compiled_module

__all__ = ["SearchResult", "global_search", "polish", "polish_batch", "METHODS"]

#: the search methods (the first is the default): differential evolution, CMA-ES, local polish only
METHODS = ("de", "cmaes", "local")

#: how many distinct good designs the probe polishes during the search
ELITE = 3
#: whether the polish takes a problem's exact Jacobian (``jacobian_batch``) where it has one
EXACT = True
#: rounds of the compiled polish between two reads of the run's clock (:class:`_CompiledRegions`)
ROUNDS = 16
#: the smallest singular value of an exact Jacobian the polish passes on, relative to the
#: largest (:func:`_floored`)
SINGULAR_FLOOR = 1e-8
#: the polish stops at a point inside the box whose residuals' RMS is at most this: a
#: relative error at rounding, which no step improves (an exact Jacobian keeps stepping
#: there until ``max_nfev``)
ROUNDING_RMS = 1e-14


@dataclass(frozen=True)
class SearchResult:
    """Best design, its objective, evaluations, seconds, and the history
    ``[(seconds, best objective, evaluations), ...]`` per generation."""

    z: np.ndarray
    fun: float
    evaluations: int
    seconds: float
    history: tuple = field(default_factory=tuple)
    stopped: str = ""


class _Counter:
    """The objective in unit-box coordinates; counts evaluations on the search's
    :class:`~.budget.Meter` (designs beyond its limit are not evaluated: ``inf``), keeps
    the best."""

    def __init__(self, problem: Problem, meter: Meter, tol: float, progress=None, probe=None):
        self.p, self.meter, self.tol, self.progress, self.probe = problem, meter, tol, progress, probe
        self.probed_t, self.done, self.probe_time = 0.0, False, 0.0
        self.lo, self.span = problem.lower, problem.upper - problem.lower
        self.n = 0
        self.best_f, self.best_z = np.inf, problem.x0.copy()
        self.elite_f, self.elite_u = np.empty(0), np.empty((0, len(problem.x0)))
        self.probed: set = set()
        self.history: list[tuple[float, float, int]] = []

    def __call__(self, U: np.ndarray) -> np.ndarray:
        Z = self.lo + np.atleast_2d(U) * self.span
        k = self.meter.take(Z.shape[0])
        f = np.full(Z.shape[0], np.inf)
        if k:
            f[:k] = self.p.batch(Z[:k])
            self.n += k
        i = int(np.argmin(f))
        if f[i] < self.best_f:
            self.best_f, self.best_z = float(f[i]), Z[i].copy()
        self._keep(np.atleast_2d(U), f)
        return f

    def _keep(self, U: np.ndarray, f: np.ndarray, k: int = ELITE, gap: float = 0.05) -> None:
        """The ``k`` best designs seen that differ pairwise by more than ``gap`` in some
        unit-box coordinate (the designs the probe polishes)."""
        if len(self.elite_f) >= k and not np.min(f) < np.max(self.elite_f):
            return                  # (no better design: the elites come first and fill the k places)
        F = np.concatenate([self.elite_f, f])
        A = np.vstack([self.elite_u, U])
        order = np.argsort(F, kind="stable")
        order = order[np.isfinite(F[order])]
        keep: list[int] = []
        while len(order) and len(keep) < k:      # (the best left; drop the designs within the gap of it)
            keep.append(int(order[0]))
            order = order[np.max(np.abs(A[order] - A[order[0]]), axis=1) > gap]
        self.elite_f, self.elite_u = F[keep], A[keep]

    def elapsed(self) -> float:
        return self.meter.elapsed()

    def generation(self) -> bool:
        """Record one generation; True when the search should stop.  Progress and the
        probes' schedule read the meter's clock: evaluations under an evaluation budget."""
        t, span = self.meter.clock(), self.meter.span()
        self.history.append((self.elapsed(), self.best_f, self.n))
        if self.progress is not None:
            self.progress(self.meter.fraction(), self.best_f)
        if self.probe is not None and t - self.probed_t >= 0.05 * span and self.probe_time <= 0.4 * t:
            # the grid objective cannot reach the tolerance (sampling); ask the polish about
            # the best few distinct designs not yet polished, spending at most 40 % of the search
            self.probed_t = t
            fresh = [u for u in self.elite_u if u.round(6).tobytes() not in self.probed]
            if fresh and not self.done:
                self.probed.update(u.round(6).tobytes() for u in fresh)
                t1 = self.meter.clock()
                self.done = bool(self.probe(self.lo + np.array(fresh) * self.span))
                self.probe_time += self.meter.clock() - t1
        return self.done or self.best_f <= self.tol or self.meter.stop() is not None


def global_search(problem: Problem, *, method: str = "de", seed: int = 0, meter: Meter | None = None,
                  tol: float = 1e-4, popsize: int = 8, progress=None, probe=None) -> SearchResult:
    """Minimise ``problem.batch`` over its bounds until ``meter`` stops it.

    ``meter`` is the search's :class:`~.budget.Meter` (default: a run of
    :data:`~.budget.DEFAULT_EVALUATIONS` evaluations).  ``popsize`` multiplies the number
    of variables (as in SciPy's DE); CMA-ES uses the same population.  The start design is
    always in the first population.  ``probe(Z) -> bool`` is called (at most every 5 % of
    the meter's span, spending at most 40 % of what the search has spent, both in the
    meter's unit) with the :data:`ELITE` best designs seen so far that differ
    pairwise by more than 0.05 in some unit-box coordinate and were not probed before,
    ``(k, n)`` (an early polish of the best few, together); it stops the search when it
    returns True (e.g. a polished design meets the tolerance).  The probe charges its evaluations
    to the same meter.  ``stopped`` is one of :data:`~.budget.STOPS`.
    """
    c = _Counter(problem, meter if meter is not None else Meter.start(Budget.of()), tol, progress, probe)
    u0 = (problem.x0 - c.lo) / np.where(c.span > 0, c.span, 1.0)
    c(u0[None, :])
    if probe is not None:                   # the start itself may be one polish away
        c.probed.add(u0.round(6).tobytes())
        c.done = bool(probe(problem.x0[None, :].copy()))
        c.probe_time = c.meter.clock()
    if method != "local" and c.best_f > tol and not c.done:
        if method == "de":
            _de(c, u0, seed, popsize)
        else:
            _cmaes(c, u0, seed, popsize)
    stopped = "tolerance" if c.best_f <= tol or c.done else (c.meter.stop() or "converged")
    return SearchResult(c.best_z, c.best_f, c.n, c.elapsed(), tuple(c.history), stopped)


def _de(c: _Counter, u0: np.ndarray, seed: int, popsize: int) -> None:
    """Differential evolution (Storn & Price 1997) in the unit box, one call of the
    objective a generation, every step vectorised over the population: SciPy's
    ``differential_evolution`` defaults as the search used them (a Latin hypercube
    start with ``u0`` its first member, strategy best/1/bin, the weight dithered in
    [0.5, 1) each generation, crossover 0.9, a component out of the box drawn again
    uniformly, deferred updating: a trial replaces its parent when no worse), without
    SciPy's per-member Python sampling (a quarter of the search's time on a four-bar)."""
    rng = np.random.default_rng(seed)
    n = len(u0)
    P = max(5, popsize * n)
    seg = (rng.random((P, n)) + np.arange(P)[:, None]) / P
    pop = np.stack([seg[rng.permutation(P), j] for j in range(n)], axis=1)
    pop[0] = u0
    f = c(pop)
    rows = np.arange(P)
    while True:
        b = int(np.argmin(f))                       # (the best first, as SciPy keeps it)
        pop[[0, b]], f[[0, b]] = pop[[b, 0]], f[[b, 0]]
        weight = rng.uniform(0.5, 1.0)
        a = rng.integers(1, P, size=P)
        d = rng.integers(1, P - 1, size=P)
        d += d >= a                                 # (two distinct others)
        trial = pop[0] + weight * (pop[(rows + a) % P] - pop[(rows + d) % P])
        cross = rng.random((P, n)) < 0.9
        cross[rows, rng.integers(0, n, size=P)] = True
        trial = np.where(cross, trial, pop)
        out = (trial < 0.0) | (trial > 1.0)
        trial[out] = rng.random(int(out.sum()))
        ft = c(trial)
        keep = ft <= f
        pop[keep], f[keep] = trial[keep], ft[keep]
        if c.generation():
            return


def _cmaes(c: _Counter, u0: np.ndarray, seed: int, popsize: int) -> None:
    import cma
    n = len(u0)
    restart = 0
    while c.meter.stop() is None and c.best_f > c.tol:
        x0 = u0 if restart == 0 else np.random.default_rng(seed + restart).random(n)
        opts = {"bounds": [0.0, 1.0], "seed": int(seed) * 1000 + restart + 1, "verbose": -9,
                "popsize": max(8, popsize * n // 2 ** min(restart, 3))}
        es = cma.CMAEvolutionStrategy(x0, 0.25, opts)
        while not es.stop():
            U = np.asarray(es.ask())
            es.tell(list(U), list(c(U)))
            if c.generation():
                return
        restart += 1


class _Deadline(Exception):
    """The polish stops with the best point seen: the meter is spent or past its deadline,
    or the residuals are at rounding (:data:`ROUNDING_RMS`)."""


def _residuals(problem: Problem, Z: np.ndarray, PHI: np.ndarray) -> np.ndarray:
    """The polish's residuals: the targets', plus the constraint penalty when there are constraints."""
    R = problem.residuals_batch(Z, PHI)
    if problem.constrained:
        R = np.concatenate([R, problem.penalty_batch(Z)[:, None]], axis=1)
    return R


def _jacobian(problem: Problem, split, U: np.ndarray, hi: np.ndarray, nz: int, free: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """Forward differences (step 1e-7, backwards at the upper bound) of the polish's
    residuals at the rows of ``U`` ``(K, n)`` (or one point ``(n,)``): the residuals
    ``(K, m)``, the Jacobians ``(K, m, n)`` and the number of designs evaluated, all in
    one batched call.  Target i's residuals depend on the design and on its own driver
    value only: all driver values are perturbed in one row, which gives the driver
    columns' diagonal blocks."""
    U = np.atleast_2d(U)
    K, n = U.shape
    h = np.where(U[:, :nz] + 1e-7 > hi[:nz], -1e-7, 1e-7)                     # (K, nz)
    rows = [U[:, None, :], np.repeat(U[:, None, :], nz, axis=1)]
    rows[1][:, np.arange(nz), np.arange(nz)] += h
    if free:
        rows.append(np.concatenate([U[:, None, :nz], U[:, None, nz:] + 1e-7], axis=2))
    W = np.concatenate(rows, axis=1)                                            # (K, 1 + nz + free, n)
    R = _residuals(problem, *split(W.reshape(-1, n)))
    R = np.where(np.isfinite(R), R, 1.0).reshape(K, W.shape[1], -1)
    J = np.zeros((K, R.shape[2], n))
    J[:, :, :nz] = np.swapaxes((R[:, 1:nz + 1] - R[:, :1]) / h[:, :, None], 1, 2)
    if free:
        n_phi = n - nz
        c = (R.shape[2] - int(problem.constrained)) // n_phi
        i = np.arange(c * n_phi)
        J[:, i, nz + i // c] = (R[:, -1, i] - R[:, 0, i]) / 1e-7
    return R[:, 0], J, W.shape[0] * W.shape[1]


def _floored(J: np.ndarray) -> np.ndarray:
    """``J`` with its singular values raised to at least :data:`SINGULAR_FLOOR` of the
    largest.  An exact Jacobian is singular where the problem has a symmetry (free
    timing: the reference pose slid along the motion with every driver value moved
    back), and SciPy's trust region takes no Gauss-Newton step from a rank-deficient
    one (it regularises every step, which converged linearly); a forward difference's
    rounding had kept those singular values near 1e-8.  The SVD is SciPy's, the LAPACK
    the trust region itself calls: NumPy's is another OpenBLAS, whose threads and
    SciPy's, each spinning after its call, fought over the 2 cores (a full-rotation
    polish of a Watt I took 330–380 ms with NumPy's SVD here, 94–98 ms with SciPy's)."""
    from scipy.linalg import svd as scipy_svd
    if J.size == 0 or not np.all(np.isfinite(J)):
        return J
    U, s, Vt = scipy_svd(J, full_matrices=False)
    low = SINGULAR_FLOOR * s[0]
    if s[-1] >= low:
        return J
    return (U * np.maximum(s, low)) @ Vt


def _unit_jacobians(problem, split: tuple, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The problem's residuals ``(K, m)`` and exact Jacobians ``(K, m, n)`` at the
    polish's points ``split`` = (Z, PHI), in its unit variables (``scale``), a
    non-finite entry zero."""
    R, J = problem.jacobian_batch(*split)
    J = J * scale
    J[~np.isfinite(J)] = 0.0
    return R, J


def _exact_jacobian(problem, split: tuple, scale: np.ndarray) -> np.ndarray:
    """The problem's exact Jacobian at the polish's point ``split`` = (Z, PHI), in its
    unit variables, floored (:func:`_floored`) up to 120 variables (beyond, LSMR's steps
    are minimum-norm)."""
    J = _unit_jacobians(problem, split, scale)[1][0]
    return _floored(J) if J.shape[1] <= 120 else J


def unit_variables(problem, z: np.ndarray, phi: np.ndarray):
    """The polish's variables (:func:`polish`): the start ``u0`` (the design in its unit
    box, with free timing the driver values in radians or mechanism sizes after it), its
    bounds ``lo``, ``hi``, the ``scale`` of each variable, and ``split(U) -> (Z, PHI)``,
    the designs and driver values of unit variables ``U``."""
    nz = len(z)
    free = problem.free_timing
    span = np.where(problem.upper > problem.lower, problem.upper - problem.lower, 1.0)
    pscale = 1.0 if problem.rotary else problem.mech_size
    scale = np.concatenate([span, np.full(len(phi), pscale)]) if free else span
    origin = np.concatenate([problem.lower, np.zeros(len(phi))]) if free else problem.lower
    lo = np.concatenate([np.zeros(nz), np.full(len(phi), -np.inf)]) if free else np.zeros(nz)
    hi = np.concatenate([np.ones(nz), np.full(len(phi), np.inf)]) if free else np.ones(nz)
    w0 = np.concatenate([z, phi]) if free else np.asarray(z, float)

    def split(U):
        W = origin + np.atleast_2d(U) * scale
        Z = W[:, :nz]
        return Z, (W[:, nz:] if free else problem.timing_for(Z))
    return np.clip((w0 - origin) / scale, lo, hi), lo, hi, scale, split


def polish(problem: Problem, z: np.ndarray, phi: np.ndarray, *, max_nfev: int = 100,
           meter: Meter | None = None, unbounded: bool = True) -> tuple[np.ndarray, np.ndarray, int]:
    """Least-squares refinement of design ``z`` and, with free timing, the driver
    values ``phi`` (one per target).

    The variables are normalised: the design to its unit box, the driver values to
    radians (or to the mechanism's size for a slider input), and the trust region
    works with unit variable scales (``x_scale=1``); the Jacobian is the problem's
    exact one where it has one (``exact_jacobian``; :func:`_floored`), else forward
    differences of step 1e-7 in these units, all perturbed designs in one batched
    call (Moré 1978 on the scaling of Levenberg–Marquardt steps); target i depends on
    its own driver value only, so one row with every driver value perturbed gives all
    of their columns (Curtis, Powell & Reid 1974: columns that share no row are
    differenced together).  The trust region
    runs unbounded first and, only when it leaves the box, again within the box from
    the best point inside it (``unbounded=False``: within the box from the start);
    only points inside the box are kept.  Stops at
    ``max_nfev`` residual evaluations, or when ``meter`` (a :class:`~.budget.Meter`,
    charged with every design evaluated) cannot afford the next residual or Jacobian
    or is past its deadline (checked before each), or once the residuals' RMS is at
    rounding (:data:`ROUNDING_RMS`), with the best point seen.  Returns
    the refined ``(z, phi)`` and the number of designs evaluated.
    """
    from scipy.optimize import least_squares
    nz = len(z)
    free = problem.free_timing
    u0, lo, hi, scale, split = unit_variables(problem, z, phi)
    count = [0]
    best = [np.inf, u0]

    def charge(rows):
        if meter is not None and (meter.late() or meter.take(rows, whole=True) < rows):
            raise _Deadline
        count[0] += rows

    def fun(u):
        charge(1)
        r = _residuals(problem, *split(u))[0]
        r = np.where(np.isfinite(r), r, 1.0)
        n = float(r @ r)
        inside = bool(np.all((u >= lo) & (u <= hi)))
        if inside and n < best[0] and (meter is None or not meter.late()):
            best[0], best[1] = n, u.copy()      # (past the deadline a slow path leaves NaN)
            if n <= r.size * ROUNDING_RMS ** 2:
                raise _Deadline
        return r

    exact = EXACT and getattr(problem, "exact_jacobian", False)

    def jac(u):
        charge(1 + nz + int(free))                  # the rows of _jacobian (what the exact one replaces)
        if exact:
            return _exact_jacobian(problem, split(u), scale)
        return _jacobian(problem, split, u, hi, nz, free)[1][0]

    # (an SVD of a few hundred columns takes seconds: beyond 120 variables the
    # trust-region subproblem is solved iteratively)
    opts = dict(jac=jac, method="trf", x_scale=1.0, xtol=1e-15, ftol=1e-15, gtol=1e-15,
                tr_solver="exact" if len(u0) <= 120 else "lsmr")
    try:
        # the box's reflective scaling (Coleman & Li 1996) slows convergence from the
        # interior by orders of magnitude: unbounded first, bounded only when it leaves the box
        sol = least_squares(fun, u0, max_nfev=max_nfev, **opts) if unbounded else None
        if sol is None or not np.all((sol.x >= lo) & (sol.x <= hi)):
            used = 0 if sol is None else sol.nfev
            least_squares(fun, best[1], bounds=(lo, hi), max_nfev=max(max_nfev - used, 10), **opts)
    except _Deadline:
        pass
    Z, PHI = split(best[1])
    return Z[0].copy(), np.array(PHI[0], float), count[0]


def _svd(J: np.ndarray, floor: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The SVDs ``W, s, Vt`` of K Jacobians ``J`` ``(K, m, n)`` that :func:`_tr_steps`
    takes, with ``floor`` the singular values raised to :data:`SINGULAR_FLOOR` of the
    largest (as :func:`_floored` raises an exact Jacobian's)."""
    W, s, Vt = np.linalg.svd(J, full_matrices=False)
    if floor:
        s = np.maximum(s, SINGULAR_FLOOR * s[:, :1])
    return W, s, Vt


def _norms(x: np.ndarray) -> np.ndarray:
    """The 2-norms of the rows of ``x`` (K, n): ``np.linalg.norm(x, axis=1)``'s own
    arithmetic (the squares summed by ``add.reduce``), without its wrapper's cost."""
    return np.sqrt(np.add.reduce(x * x, axis=1))


def _tr_propose(svd: tuple, R: np.ndarray, J: np.ndarray, radius: np.ndarray, alpha: np.ndarray):
    """:func:`_tr_steps`'s steps ``h`` and parameters, and each step's predicted
    reduction ``|r|² − |r + J h|²`` (compiled as ``_trust_nb.tr_propose`` when populations
    run compiled)."""
    nb = compiled_module("_trust_nb")
    if nb is not None:
        return nb.tr_propose(*(np.ascontiguousarray(x, float) for x in (*svd, R, J, radius, alpha)))
    h, alpha = _tr_steps(svd, R, radius, alpha)
    Jh = np.einsum("kmi,ki->km", J, h)
    return h, alpha, -(2.0 * np.einsum("km,km->k", R, Jh) + np.einsum("km,km->k", Jh, Jh))


def _tr_accept(F: np.ndarray, Fn: np.ndarray, pred: np.ndarray, h: np.ndarray, U: np.ndarray,
               radius: np.ndarray, alpha: np.ndarray):
    """SciPy ``trf``'s verdict on K steps ``h`` from ``U`` (squared residuals ``F`` before,
    ``Fn`` after, ``pred`` predicted): the new radii and Levenberg–Marquardt parameters
    (the ratio of actual to predicted reduction below 0.25: a quarter of the step; above
    0.75 on the boundary: doubled) and whether each design has stopped (``ftol``,
    ``xtol`` at 1e-15); compiled as ``_trust_nb.tr_accept`` when populations run compiled."""
    nb = compiled_module("_trust_nb")
    if nb is not None:
        return nb.tr_accept(*(np.ascontiguousarray(x, float) for x in (F, Fn, pred, h, U, radius, alpha)))
    gain = F - Fn
    rho = np.where(pred > 0, gain / np.where(pred > 0, pred, 1.0), np.where((pred == 0) & (gain == 0), 1.0, 0.0))
    step = _norms(h)
    new_radius = np.where(rho < 0.25, 0.25 * step, np.where((rho > 0.75) & (step > 0.95 * radius), 2.0 * radius, radius))
    done = ((gain < 1e-15 * F) & (rho > 0.25)) | (step < 1e-15 * (1e-15 + _norms(U)))
    alpha = np.where(done, alpha, alpha * radius / np.where(new_radius > 0, new_radius, 1.0))
    return np.where(done, radius, new_radius), alpha, done


def _tr_steps(svd: tuple, R: np.ndarray, radius: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The trust-region steps ``h`` ``(K, n)`` of K least-squares problems ``|r + J h|``
    (``J`` ``(m, n)`` given by its :func:`_svd`) within ``|h| <= radius``, and their
    Levenberg–Marquardt parameters ``alpha`` (the last ones, ``alpha``, start the
    search): SciPy's ``solve_lsq_trust_region`` (Moré 1977, on one SVD of ``J``) for all
    K at once, step for step — the Gauss–Newton step of a full-rank ``J`` where it fits,
    else ``alpha`` by at most ten safeguarded Newton steps to 1 % of the radius and the
    step scaled onto it."""
    W, s, Vt = svd
    K, m, n = len(R), W.shape[1], Vt.shape[2]
    uf = np.einsum("kmi,km->ki", W, R)
    suf = s * uf
    full = (m >= n) & (s[:, -1] > np.finfo(float).eps * m * s[:, 0])
    gn = -np.einsum("kij,ki->kj", Vt, np.divide(uf, s, out=np.zeros_like(uf), where=full[:, None]))
    fits = full & (_norms(gn) <= radius)

    def phi(al):
        den = s * s + al[:, None]
        norm = _norms(suf / den)
        return norm - radius, -np.sum(suf ** 2 / den ** 3, axis=1) / norm

    upper = _norms(suf) / radius
    with np.errstate(divide="ignore", invalid="ignore"):     # (a zero singular value: its row not full, unused)
        f0, d0 = phi(np.zeros(K))
    lower = np.where(full, -f0 / d0, 0.0)
    reset = np.maximum(1e-3 * upper, np.sqrt(np.maximum(lower * upper, 0.0)))     # (rows that fit: unused)
    alpha = np.where(~full & (alpha == 0), reset, alpha)
    live = ~fits
    for _ in range(10):
        if not live.any():
            break
        reset = np.maximum(1e-3 * upper, np.sqrt(np.maximum(lower * upper, 0.0)))
        alpha = np.where(live & ((alpha < lower) | (alpha > upper)), reset, alpha)
        f, d = phi(alpha)
        upper = np.where(live & (f < 0), alpha, upper)
        ratio = f / d
        lower = np.where(live, np.maximum(lower, alpha - ratio), lower)
        alpha = np.where(live, alpha - (f + radius) * ratio / radius, alpha)
        live &= ~(np.abs(f) < 0.01 * radius)
    h = -np.einsum("kij,ki->kj", Vt, suf / (s * s + alpha[:, None]))
    h *= (radius / _norms(h))[:, None]
    return np.where(fits[:, None], gn, h), np.where(fits, 0.0, alpha)


def polish_batch(problem: Problem, Z: np.ndarray, PHI: np.ndarray, *, max_nfev: int = 100,
                 meter: Meter | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`polish` of K designs ``Z`` ``(K, n)`` and, with free timing, their driver
    values ``PHI`` ``(K, N)``, all at once: every residual and Jacobian call scores the
    designs still moving in one batch (one pass over the compiled plan), so a polish of
    several starts costs about what one costs.

    The same variables, Jacobian, stops and charges as :func:`polish`, and its
    trust region's iteration (SciPy's ``trf`` without bounds: Branch, Coleman & Li
    1999; the radius a quarter of the step below a ratio of 0.25, doubled above 0.75 on
    the boundary; the step the exact solution of the subproblem, :func:`_tr_steps`),
    run for every design together.  A design stops after ``max_nfev`` residual
    evaluations, at a residual RMS of :data:`ROUNDING_RMS`, or when its step is below
    rounding; all stop when ``meter`` cannot afford the next call or is past its
    deadline.  The best point inside the box is kept; a design whose iteration ended
    outside the box is polished again within it from there (:func:`polish`,
    ``unbounded=False``).  Beyond 120 variables (where :func:`polish` solves the
    subproblem iteratively) the designs are polished by :func:`polish` itself (SciPy's
    ``least_squares``), one by one; one design is polished here too (the same steps as
    SciPy's, each step one compiled call: 7 % fewer instructions in a whole four-bar
    run than SciPy's iteration, the same design).  Returns the refined
    ``Z``, ``PHI`` and the number of designs evaluated.
    """
    Z = np.atleast_2d(np.asarray(Z, float))
    PHI = np.atleast_2d(np.asarray(PHI, float))
    nz = Z.shape[1]
    free = problem.free_timing
    if nz + (PHI.shape[1] if free else 0) > 120:     # (SciPy's own: LSMR's)
        out = [polish(problem, z, phi, max_nfev=max_nfev, meter=meter) for z, phi in zip(Z, PHI)]
        return np.array([o[0] for o in out]), np.array([o[1] for o in out]), sum(o[2] for o in out)
    starts = [unit_variables(problem, z, phi) for z, phi in zip(Z, PHI)]
    _, lo, hi, scale, split = starts[0]
    U = np.stack([s[0] for s in starts])
    exact = EXACT and getattr(problem, "exact_jacobian", False)
    count = [0]

    def afford(rows: int) -> bool:
        if meter is not None and (meter.late() or meter.take(rows, whole=True) < rows):
            return False
        count[0] += rows
        return True

    def with_jacobian(Ua):
        if not afford(Ua.shape[0] * (1 + nz + int(free))):
            return None
        if exact:
            R, J = _unit_jacobians(problem, split(Ua), scale)
        else:
            R, J, _ = _jacobian(problem, split, Ua, hi, nz, free)
        return np.where(np.isfinite(R), R, 1.0), J

    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        tracer = _CompiledRegions.route(problem) if exact and free else None
        if tracer is not None:
            run = _CompiledRegions(problem, tracer, U, lo, hi, scale, meter)
            run.iterate(max_nfev, 1 + nz + int(free))
            count[0] += run.used
        else:
            run = _TrustRegions(problem, U, lo, hi, split, afford, meter, floor=exact)
            run.iterate(with_jacobian, max_nfev)
    Zs, PHIs = split(run.best_u)
    Zs, PHIs = Zs.copy(), np.array(PHIs, float)
    for k in np.flatnonzero(run.left_box & (meter is None or meter.stop() is None)):
        Zs[k], PHIs[k], n = polish(problem, Zs[k], PHIs[k], max_nfev=max(max_nfev - int(run.nfev[k]), 10),
                                   meter=meter, unbounded=False)
        count[0] += n
    return Zs, PHIs, count[0]


class _TrustRegions:
    """:func:`polish_batch`'s iteration: K trust regions over the unit variables ``U``
    ``(K, n)``, the best point inside the box ``best_u`` of each, its residual
    evaluations ``nfev`` and whether its iteration ended outside the box ``left_box``."""

    def __init__(self, problem: Problem, U: np.ndarray, lo, hi, split, afford, meter, floor: bool):
        self.problem, self.U, self.lo, self.hi, self.split, self.afford = problem, U, lo, hi, split, afford
        self.meter, self.floor = meter, floor
        self.best_u, self.best_f = U.copy(), np.full(len(U), np.inf)
        self.nfev = np.ones(len(U), int)
        self.left_box = np.zeros(len(U), bool)

    def _keep(self, k: np.ndarray, Un: np.ndarray, Fn: np.ndarray) -> None:
        """Keep the points ``Un`` of designs ``k`` that are inside the box and better."""
        if self.meter is not None and self.meter.late():
            return                              # (past the deadline a slow path leaves NaN)
        better = np.all((Un >= self.lo) & (Un <= self.hi), axis=1) & (Fn < self.best_f[k])
        self.best_u[k[better]], self.best_f[k[better]] = Un[better], Fn[better]

    def iterate(self, with_jacobian, max_nfev: int) -> None:
        """SciPy's ``trf_no_bounds`` loop for every design at once (the same radius
        updates, Levenberg–Marquardt warm starts and tests: ``gtol``, ``ftol``, ``xtol``
        at 1e-15), until each has stopped."""
        U = self.U
        first = with_jacobian(U)
        if first is None:
            return
        R, J = first
        F = np.einsum("km,km->k", R, R)
        self._keep(np.arange(len(U)), U, F)
        norm = _norms(U)
        radius, alpha = np.where(norm > 0, norm, 1.0), np.zeros(len(U))
        rounding = R.shape[1] * ROUNDING_RMS ** 2
        active = (F > rounding) & (np.max(np.abs(np.einsum("kmi,km->ki", J, R)), axis=1) >= 1e-15)
        W, s, Vt = _svd(J, self.floor)           # (a rejected step's design keeps its Jacobian's)
        while active.any():
            a = np.flatnonzero(active)
            h, alpha[a], pred = _tr_propose((W[a], s[a], Vt[a]), R[a], J[a], radius[a], alpha[a])
            if not self.afford(len(a)):
                break
            Un = U[a] + h
            Rn = _residuals(self.problem, *self.split(Un))
            Rn = np.where(np.isfinite(Rn), Rn, 1.0)
            self.nfev[a] += 1
            Fn = np.einsum("km,km->k", Rn, Rn)
            self._keep(a, Un, Fn)
            radius[a], alpha[a], done = _tr_accept(F[a], Fn, pred, h, U[a], radius[a], alpha[a])
            ok = F[a] - Fn > 0
            acc = a[ok]
            if len(acc):
                new = with_jacobian(Un[ok])
                if new is None:
                    U[acc] = Un[ok]
                    break
                U[acc], (R[acc], J[acc]), F[acc] = Un[ok], new, Fn[ok]
                W[acc], s[acc], Vt[acc] = _svd(J[acc], self.floor)
                flat = np.max(np.abs(np.einsum("kmi,km->ki", J[acc], R[acc])), axis=1) < 1e-15
                active[acc[flat]] = False
            active[a[done]] = False
            active &= (self.nfev < max_nfev) & (F > rounding)
        self._ended(U)

    def _ended(self, U: np.ndarray) -> None:
        """Record whether each design's iteration ended outside the box."""
        self.left_box = ~np.all((U >= self.lo) & (U <= self.hi), axis=1)


class _CompiledRegions(_TrustRegions):
    """:class:`_TrustRegions`'s iteration compiled (:mod:`._polish_nb`) for a path
    target's tracer with free timing and no constraint (:meth:`route`): rounds of the
    same iteration in one call, the run's ``meter`` charged and its clock read between
    calls (every :data:`ROUNDS` rounds).  The same ``best_u``, ``nfev`` and ``left_box``;
    ``used`` the evaluations charged."""

    def __init__(self, problem: Problem, tracer, U: np.ndarray, lo, hi, scale, meter):
        super().__init__(problem, U, lo, hi, None, None, meter, floor=True)
        self.scale = np.ascontiguousarray(scale, float)
        self.origin = np.concatenate([problem.lower, np.zeros(U.shape[1] - len(problem.lower))])
        self.tr = tracer.compiled_parts()
        T, size = problem.targets_for(U[:1])
        self.T, self.size = np.ascontiguousarray(T[0], float), float(size[0])
        self.used = 0

    @staticmethod
    def route(problem: Problem):
        """The problem's tracer batch when this route applies (a path target, not shape
        only, free timing, no constraint, the tracer compiled), else None."""
        t = problem.target
        if problem.constrained or not problem.free_timing or getattr(t, "shape_only", True):
            return None
        return problem._tracer()

    def _charge(self, n: float, refused: bool) -> bool:
        """Charge ``n`` evaluations to the meter; False once the iteration must stop."""
        self.used += int(n)
        if self.meter is not None:
            self.meter.settle(int(n), refused)
        return not refused

    def _avail(self) -> float:
        return np.inf if self.meter is None else float(self.meter.left())

    def iterate(self, max_nfev: int, cost: int) -> None:
        """Until each design has stopped (see :meth:`_TrustRegions.iterate`)."""
        nb = compiled_module("_polish_nb")
        U, K = self.U, len(self.U)
        m = 2 * self.problem.n_targets
        r = min(m, U.shape[1])
        R, J = np.empty((K, m)), np.empty((K, m, U.shape[1]))
        Wsv, s, Vt, F = np.empty((K, m, r)), np.empty((K, r)), np.empty((K, r, U.shape[1])), np.empty(K)
        if self.meter is not None and self.meter.late():
            return
        if not self._charge(*((K * cost, False) if self._avail() >= K * cost else (0, True))):
            return
        norm = _norms(U)
        radius, alpha = np.where(norm > 0, norm, 1.0), np.zeros(K)
        rounding = m * ROUNDING_RMS ** 2
        active = np.ones(K, bool)

        def run(most: int):
            return nb.rounds(self.tr, self.origin, self.scale, len(self.problem.lower), self.T, self.size, self.lo,
                             self.hi, U, R, J, Wsv, s, Vt, F, radius, alpha, active, self.nfev, self.best_u,
                             self.best_f, max_nfev, rounding, SINGULAR_FLOOR, self._avail(), float(cost), most)
        run(0)                                     # (the starts: residuals, Jacobians, SVDs; flat ones stop)
        inside = np.all((U >= self.lo) & (U <= self.hi), axis=1)
        self.best_u[inside], self.best_f[inside] = U[inside], F[inside]
        active &= F > rounding
        while active.any() and not (self.meter is not None and self.meter.late()):
            if not self._charge(*run(ROUNDS)):
                break
        self._ended(U)
