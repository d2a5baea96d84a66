"""Run Pyslvs's path synthesis on one target (a peer for ``bench_synthesis.py``).

Runs under an interpreter that has ``pyslvs`` (22.7.0 builds from its sdist with
``pip install 'cython<3.1' wheel`` then ``pip wheel --no-build-isolation --no-deps
pyslvs==22.7.0``); it does not import multiloop.  Reads one JSON object on stdin::

    {"expression": "M[...]", "input": [[b, d]], "target": [[x, y], ...],
     "box": [xlo, ylo, xhi, yhi], "upper": L, "max_time": S, "algorithm": "DE"}

and prints ``{"version", "expression", "fitness", "wall", "evaluations", "history"}``.

Pyslvs's objective (``pyslvs.optimization.FPlanar``): the ground pivots move in the
square ``box`` (centre ± half side), every link length in ``[0, upper]``, and one
input angle per target point in ``[0°, 360°]`` (free timing); the fitness is the sum
of distances from the tracer to its targets, each target solved on its own.  The
search is Pyslvs's own metaheuristic (``pyslvs.metaheuristics``, default settings of
the algorithm) stopped by ``max_time`` (whole seconds: Pyslvs times with ``time()``).
"""
import json
import sys
import time


def main() -> int:
    import pyslvs
    from pyslvs import parse_vpoints
    from pyslvs.metaheuristics import AlgorithmType, algorithm, default
    from pyslvs.optimization import FPlanar

    job = json.load(sys.stdin)
    vpoints = parse_vpoints(job["expression"])
    tracer = [i for i, vp in enumerate(vpoints) if len(vp.links) == 1]
    ground = [i for i, vp in enumerate(vpoints) if vp.grounded()]
    xlo, ylo, xhi, yhi = job["box"]
    half = max(xhi - xlo, yhi - ylo) / 2
    centre = ((xlo + xhi) / 2, (ylo + yhi) / 2)
    mech = {"expression": vpoints,
            "input": [(tuple(p), [0.0, 360.0]) for p in job["input"]],
            "placement": {i: (centre[0], centre[1], half) for i in ground},
            "target": {tracer[0]: [tuple(p) for p in job["target"]]},
            "same": {}, "upper": job["upper"], "lower": 0.0, "shape_only": False}
    func = FPlanar(mech)
    kind = AlgorithmType[job.get("algorithm", "DE")]
    settings = default(kind)
    settings.pop("max_gen", None)          # Pyslvs checks max_gen before max_time
    settings["max_time"] = job["max_time"]
    t0 = time.perf_counter()
    alg = algorithm(kind)(func, settings)
    expr = alg.run()
    wall = time.perf_counter() - t0
    _, fitness = alg.result()
    hist = [list(map(float, row)) for row in alg.history()]
    json.dump({"version": pyslvs.__version__, "expression": expr, "fitness": float(fitness),
               "wall": wall, "evaluations": int(func.callback), "history": hist}, sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
