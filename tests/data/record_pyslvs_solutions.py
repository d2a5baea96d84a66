"""Record Pyslvs's own position solutions of its bundled examples (run by hand).

    pip install 'cython<3.1' wheel
    pip wheel --no-build-isolation --no-deps pyslvs==22.7.0 && pip install pyslvs-22.7.0-*.whl
    python tests/data/record_pyslvs_solutions.py > tests/data/pyslvs_solutions.json

For every example of ``pyslvs.example_list`` this stores the expression and input pairs
as Pyslvs ships them, and Pyslvs's solution (``pyslvs.expr_solving`` on
``pyslvs.t_config``) at the reference input angles plus a few offsets (every input
turned by the same offset, degrees).  A position is a joint's ``[x, y]``, or for a
P/RP joint ``[[x, y] on the slot link, [x, y] on the slider]``.  Offsets at which
Pyslvs fails to assemble are left out.  The test compares multiloop's solve of the
imported project against these numbers, so it does not need Pyslvs installed.
"""
from __future__ import annotations

import json
import math

import pyslvs
from pyslvs import all_examples, example_list, expr_solving, parse_vpoints, t_config

OFFSETS = (0.0, 10.0, 25.0, -20.0, 45.0)


def _angle(vp, b, d):
    (xb, yb), (xd, yd) = vp[b].c[0], vp[d].c[0]
    return math.degrees(math.atan2(yd - yb, xd - xb))


def _pos(p):
    if isinstance(p[0], (tuple, list)):
        return [[float(p[0][0]), float(p[0][1])], [float(p[1][0]), float(p[1][1])]]
    return [float(p[0]), float(p[1])]


def main() -> None:
    out = {"pyslvs_version": pyslvs.__version__,
           "how": "pyslvs.expr_solving(pyslvs.t_config(vpoints, inputs), vpoints, angles); "
                  "angles in degrees, absolute direction from the base joint to the driver joint",
           "examples": {}}
    for name in all_examples():
        expr, inputs = example_list(name)
        if not inputs:
            continue
        vp = parse_vpoints(expr)
        ref = {tuple(i): _angle(vp, *i) for i in inputs}
        try:
            exprs = t_config(vp, inputs)
        except Exception:  # noqa: BLE001 - an example Pyslvs cannot plan is skipped
            continue
        sols = []
        for off in OFFSETS:
            angles = {k: a + off for k, a in ref.items()}
            try:
                res = expr_solving(exprs, vp, angles)
            except Exception:  # noqa: BLE001 - not assembled at this input
                continue
            sols.append({"offset_deg": off, "angles_deg": [angles[tuple(i)] for i in inputs],
                         "positions": [_pos(p) for p in res]})
        out["examples"][name] = {"expression": expr, "input": [list(i) for i in inputs],
                                 "solutions": sols}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
