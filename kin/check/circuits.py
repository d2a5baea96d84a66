"""Assembly modes of every group at the reference and which ones motion reaches.

A dyad with a reach limit (RRR, RRP, RPR) has two assembly modes (Vasechkin et al.
2017); PRP and RPP have one.  A triad or a class IV group has up to six, all found by
the degree-6 polynomial of the all-modes kernel (Hunt 1983).  Continuous motion of the
drivers reaches another mode of a group only through a singular position of that
group (Chase & Mirth 1993): at a limit (a turning point, where the driver must reverse
to go on and the group flips into its other mode) or at a branch point (a change
point, where two modes cross).  So a mode counts as reachable when the reference mode
meets such a position of the group; a group that never meets one stays on its
reference mode (its other modes are other circuits, reachable only by disassembly).
"""
from __future__ import annotations

from multiloop.kin.groups.registry import mode_count

from .report import GroupCircuit

__all__ = ["group_circuits"]


def group_circuits(ap, drivers) -> tuple[GroupCircuit, ...]:
    """One :class:`GroupCircuit` per group of the plan ``ap``."""
    out = []
    for g in ap.groups:
        lab = g.describe()
        n = mode_count(ap.mechanism, g)
        at_limit = [f"{dc.joint} limit" for dc in drivers for s in dc.limit_groups if s.startswith(lab)]
        at_branch = [f"{dc.joint} branch point" for dc in drivers for _, b in dc.branch_points if b == lab]
        if n is None:
            out.append(GroupCircuit(lab, g.kind_name, None, None,
                                    "modes not enumerated for this group (no kernel for its "
                                    "kind: solved by Newton from the reference)"))
            continue
        via = at_limit + at_branch
        reach = min(n, 2) if via and n > 1 else 1
        note = ("reference mode only; the others need disassembly" if reach == 1 and n > 1 else
                "single mode" if n == 1 else
                "reference mode and the mode met through " + ", ".join(sorted(set(via))))
        out.append(GroupCircuit(lab, g.kind_name, n, reach, note))
    return tuple(out)
