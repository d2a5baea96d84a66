"""Pyslvs projects in and out: the ``.pyslvs`` YAML project and the bare expression.

Pyslvs (Chang & Chen, Pyslvs-UI) describes a planar linkage by one expression,
``M[J[R, color[Green], P[x, y], L[ground, L1, L2]], …]``: a list of joints, each with
its kind, an optional slider angle ``A[deg]``, a colour, its position and *all* the
links on it (so multiple joints are native).  The project file is YAML with the
expression under ``mechanism`` and the drivers under ``input`` as ``[base, driver]``
joint-index pairs.

Mapping to the multiloop model (read and written the same way):

* joints are named ``P0, P1, …`` in expression order; the link called ``ground`` is
  the frame; the other link names are kept;
* ``R`` on two or more links is an R joint (a multiple joint when more than two); ``R``
  on one link is a tracer point of that name on that link;
* ``P`` on links ``[s, b]`` (slot link first) is a P joint with guide ``s``, slider
  ``b``, through the joint's position with axis ``(cos A, sin A)``: ``b`` slides along
  ``s`` without turning relative to it;
* ``RP`` on links ``[s, l1, …]`` is a slider block on the slot of ``s`` with the other
  links pinned to it: a new link ``P<i>_block``, a P joint ``P<i>_slot`` (guide ``s``,
  slider the block, axis ``A``) and an R joint ``P<i>`` (the block and ``l1, …``) at the
  joint's position; writing recognises this pattern and gives ``RP`` back;
* an input ``[b, d]`` drives the link that joints ``b`` and ``d`` share, about joint
  ``b``, relative to the frame (Pyslvs gives the absolute direction of ``b → d``;
  multiloop's input is its change from the reference); ``[b, b]`` on a P/RP joint
  drives the slide;
* coordinates are taken as they are (Pyslvs stores no unit).

A P joint on more than two links (several links fixed to one slider) has no
multiloop equivalent and is refused with a message.  Writing refuses a link name that
is not a Pyslvs name (letters, digits and ``_``, not starting with a digit: a ``,`` or
``]`` would change the chain read back) and names what the format cannot keep
(:func:`pyslvs_losses`): masses, loads, gravity, driver speeds and ranges, joint and
point names.
A driver written frame-second (``links = [b, frame]``) is exported as ``b`` driven
relative to the frame; its input is the negative of the file's.

Examples
--------
>>> m = mechanism_from_expression(
...     "M[J[R, color[Green], P[0, 0], L[ground, L1]], J[R, color[Green], P[10, 0], L[L1, L2]],"
...     " J[R, color[Green], P[30, 20], L[L2, L3]], J[R, color[Green], P[40, 0], L[ground, L3]]]",
...     inputs=[(0, 1)])
>>> m.joint_names, m.frame, m.drivers[0].links
(('P0', 'P1', 'P2', 'P3'), 'ground', ('ground', 'L1'))
>>> expression_of(m)[1]
[(0, 1)]
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import JointKind, Mechanism, MechanismBuilder

__all__ = ["PyslvsJoint", "with_pyslvs_names", "parse_expression", "mechanism_from_expression", "read_pyslvs", "loads_pyslvs",
           "expression_of", "dumps_expression", "dumps_pyslvs", "write_pyslvs", "pyslvs_losses",
           "MAX_YAML_DEPTH"]

GROUND = "ground"
_JOINT = re.compile(r"J\[\s*(RP|R|P)\s*,(?P<body>[^J]*?)L\[(?P<links>[^\]]*)\]\s*\]")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_FIELD = {"A": re.compile(r"(?<![A-Za-z_])A\[([^\]]*)\]"),
          "P": re.compile(r"(?<![A-Za-z_])P\[([^\]]*)\]"),
          "color": re.compile(r"color\[([^\]]*)\]")}


@dataclass(frozen=True)
class PyslvsJoint:
    """One ``J[...]`` of a Pyslvs expression."""

    kind: str
    links: tuple[str, ...]
    x: float
    y: float
    angle: float = 0.0
    color: str = "Green"


def _floats(text: str, n: int, where: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(explain(where, expected=f"{n} finite number(s)", got=repr(text[:60])))
    return vals


def parse_expression(expr: str) -> list[PyslvsJoint]:
    """The joints of a Pyslvs expression, in order (InputError on anything else)."""
    text = " ".join(str(expr).split())
    if not (text.startswith("M[") and text.endswith("]")):
        raise InputError(explain("Pyslvs expression", expected="M[J[...], ...]", got=repr(text[:40])))
    inner, joints, pos = text[2:-1], [], 0
    for mt in _JOINT.finditer(inner):
        if inner[pos:mt.start()].strip(" ,"):
            break
        pos = mt.end()
        where = f"Pyslvs joint {len(joints)} ({mt.group(0)[:40]})"
        body = mt.group("body")
        xy = _FIELD["P"].search(body)
        if xy is None:
            raise InputError(explain(where, expected="a position P[x, y]", got="none"))
        x, y = _floats(xy.group(1), 2, where)
        a = _FIELD["A"].search(body)
        c = _FIELD["color"].search(body)
        links = tuple(s.strip() for s in mt.group("links").split(",") if s.strip())
        joints.append(PyslvsJoint(mt.group(1), links, x, y,
                                  _floats(a.group(1), 1, where)[0] if a else 0.0,
                                  c.group(1).strip() if c else "Green"))
    if inner[pos:].strip(" ,"):
        raise InputError(explain("Pyslvs expression", expected="J[kind, ..., P[x, y], L[links]] items",
                                 got=repr(inner[pos:pos + 40])))
    return joints


def _add_joint(b: MechanismBuilder, i: int, j: PyslvsJoint) -> None:
    name, where = f"P{i}", f"Pyslvs joint P{i}"
    axis = (math.cos(math.radians(j.angle)), math.sin(math.radians(j.angle)))
    if j.kind == "R":
        if not j.links:
            raise InputError(explain(where, expected="at least one link", got="L[]"))
        if len(j.links) == 1:
            b.add_point(name, j.links[0], (j.x, j.y))
        else:
            b.add_joint(name, "R", j.links, at=(j.x, j.y))
    elif j.kind == "P":
        if len(j.links) != 2:
            raise InputError(explain(where, expected="a P joint on exactly two links (slot, slider)",
                                     got=f"{len(j.links)} links {list(j.links)}",
                                     hint="several links fixed to one slider have no multiloop "
                                          "equivalent; use RP (a pinned block) or merge the links"))
        b.add_joint(name, "P", j.links, at=(j.x, j.y), axis=axis)
    else:  # RP: a block sliding on the slot of links[0], pinned to the others
        if len(j.links) < 2:
            raise InputError(explain(where, expected="an RP joint on a slot link and one or more links",
                                     got=f"{list(j.links)}"))
        block = f"{name}_block"
        b.add_joint(f"{name}_slot", "P", (j.links[0], block), at=(j.x, j.y), axis=axis)
        b.add_joint(name, "R", (block, *j.links[1:]), at=(j.x, j.y))


def _add_driver(b: MechanismBuilder, joints: list[PyslvsJoint], pair) -> None:
    try:
        if not isinstance(pair, (list, tuple)) or len(pair) < 2 \
                or not all(isinstance(v, int) and not isinstance(v, bool) for v in pair[:2]):
            raise TypeError
        base, drv = pair[0], pair[1]
        jb, jd = joints[base], joints[drv]
        if base < 0 or drv < 0:
            raise IndexError
    except (TypeError, ValueError, IndexError):
        raise InputError(explain("Pyslvs input", expected=f"[base, driver] joint indices < {len(joints)}",
                                 got=repr(pair)[:60])) from None
    where = f"Pyslvs input [{base}, {drv}]"
    if base == drv:
        if jb.kind == "R":
            raise InputError(explain(where, expected="a P or RP joint for a slide input", got="an R joint"))
        b.add_driver(f"P{base}" if jb.kind == "P" else f"P{base}_slot")
        return
    shared = [lk for lk in jb.links if lk in jd.links and lk != GROUND]
    if len(shared) != 1 or GROUND not in jb.links or jb.kind != "R":
        raise InputError(explain(where, expected=f"joints sharing one moving link, base P{base} an R joint "
                                 "on the ground", got=f"shared links {shared}, base links {list(jb.links)}",
                                 hint="multiloop drives a link relative to the frame about a frame pin"))
    b.add_driver(f"P{base}", (GROUND, shared[0]))


def mechanism_from_expression(expr: str, inputs=(), name: str | None = None) -> Mechanism:
    """A :class:`Mechanism` from a Pyslvs expression and its ``[base, driver]`` inputs."""
    joints = parse_expression(expr)
    b = MechanismBuilder(name=name, source="imported from a Pyslvs expression")
    links: list[str] = []
    for j in joints:
        links += [lk for lk in j.links if lk not in links]
    for lk in links:
        b.add_link(lk, frame=lk == GROUND)
    for i, j in enumerate(joints):
        _add_joint(b, i, j)
    for lk in (f"P{i}_block" for i, j in enumerate(joints) if j.kind == "RP"):
        b.add_link(lk)
    if not isinstance(inputs, (list, tuple)):
        raise InputError(explain("Pyslvs input", expected="a list of [base, driver] joint-index pairs",
                                 got=repr(inputs)[:60]))
    for pair in inputs:
        _add_driver(b, joints, pair)
    return b.build()


#: deepest YAML nesting read (a project needs 3)
MAX_YAML_DEPTH = 32


def _yaml_document(text: str, where: str):
    """The YAML document of ``text``, refusing aliases and nesting beyond
    :data:`MAX_YAML_DEPTH` before anything is built (an alias bomb expands a few
    hundred bytes into gigabytes; deep nesting exhausts the recursion)."""
    import yaml  # noqa: PLC0415 - only needed for Pyslvs files

    depth = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
                raise InputError(explain(where, expected="a Pyslvs YAML project without anchors or aliases",
                                         got=f"an {'alias' if isinstance(event, yaml.AliasEvent) else 'anchor'}",
                                         hint="Pyslvs writes none; write the values out"))
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_YAML_DEPTH:
                    raise InputError(explain(where, expected=f"YAML nested at most {MAX_YAML_DEPTH} deep",
                                             got="deeper nesting"))
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
        return yaml.safe_load(text)
    except InputError:
        raise
    except yaml.YAMLError as exc:
        raise InputError(explain(where, expected="a Pyslvs YAML project",
                                 got=f"invalid YAML ({str(exc).splitlines()[0][:120]})")) from None
    except (RecursionError, ValueError, OverflowError) as exc:
        raise InputError(explain(where, expected="a Pyslvs YAML project",
                                 got=f"unreadable YAML ({type(exc).__name__})")) from None


def read_pyslvs(path: str | Path) -> Mechanism:
    """A mechanism from a ``.pyslvs`` project (YAML) or a file holding a bare expression.

    Raises
    ------
    InputError
        A non-regular or oversized file (:func:`~topo.io.read_input_bytes`), non-UTF-8
        text, YAML with anchors, aliases or deep nesting, or a faulty expression or input.
    """
    from multiloop.topo.io import read_input_bytes  # noqa: PLC0415

    p = Path(path)
    try:
        text = read_input_bytes(p).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(explain(f"file '{p}'", expected="UTF-8 text", got=f"undecodable bytes ({exc.reason})")) from None
    return loads_pyslvs(text, str(p), name=p.stem)


def loads_pyslvs(text: str, where: str = "<string>", name: str | None = None) -> Mechanism:
    """A mechanism from the text of a ``.pyslvs`` project or a bare expression;
    ``where`` names the source in messages, ``name`` names the mechanism."""
    try:
        if text.lstrip().startswith("M["):
            return mechanism_from_expression(text, name=name)
        doc = _yaml_document(text, f"file '{where}'")
        if not isinstance(doc, dict) or not isinstance(doc.get("mechanism"), str):
            raise InputError(explain(f"file '{where}'", expected="a YAML mapping with a 'mechanism' expression",
                                     got=type(doc).__name__ if not isinstance(doc, dict) else "no 'mechanism' key"))
        inputs = doc.get("input")
        return mechanism_from_expression(doc["mechanism"], () if inputs is None else inputs, name=name)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(f"file '{where}'") else f"{where}: {msg}") from None


#: significant digits of every exported coordinate and guide angle (Pyslvs keeps floats
#: as text; 12 digits keep a round trip within 1e-12 of the size, not bit for bit)
DIGITS = 12
#: the first line of a written ``.pyslvs`` project (a YAML comment: Pyslvs ignores it)
HEADER = (f"# written by multiloop: coordinates and guide angles rounded to {DIGITS} "
          "significant digits\n")


def _fmt(v: float) -> str:
    return format(float(v), f".{DIGITS}g")


def _blocks(m: Mechanism) -> dict[str, str]:
    """R joint name → P joint name for the RP pattern (a block with one P and one R joint)."""
    out: dict[str, str] = {}
    driven = {lk for d in m.drivers for lk in d.links} | {pt.link for pt in m.points}
    for j in m.joints:
        if j.kind is not JointKind.P or j.links[1] in driven or m.link(j.links[1]).is_frame:
            continue
        on = m.joints_of(j.links[1])
        pins = [r for r in on if r.kind is JointKind.R]
        if len(on) == 2 and len(pins) == 1 and len(pins[0].links) >= 2 and pins[0].at is not None \
                and j.at is not None and math.dist(pins[0].at, j.at) < 1e-9:
            out[pins[0].name] = j.name
    return out


def _ground(m: Mechanism, name: str) -> str:
    return GROUND if name == m.frame else name


def _entries(m: Mechanism) -> tuple[list[str], dict[str, int]]:
    """The ``J[...]`` items and the index of every joint / point name."""
    if not m.has_geometry or m.frame is None:
        raise InputError(explain(f"mechanism '{m.name}'" if m.name else "the mechanism",
                                 expected="a frame and every joint's position",
                                 got="a bare chain", hint="Pyslvs needs positions and a ground link"))
    if m.frame != GROUND and GROUND in m.link_names:
        raise InputError(explain("link 'ground'", expected="the frame (Pyslvs's fixed link)",
                                 got=f"a moving link while the frame is '{m.frame}'"))
    bad = [lk for lk in m.link_names if lk != m.frame and not _NAME.fullmatch(lk)]
    if bad:
        raise InputError(explain(f"link '{bad[0][:60]}'" + (f" and {len(bad) - 1} more" if len(bad) > 1 else ""),
                                 expected="a Pyslvs link name (letters, digits and '_', not starting with a digit)",
                                 got="other characters",
                                 hint="rename the link: Pyslvs would read a different chain"))
    blocks = _blocks(m)
    absorbed = set(blocks.values())
    items, index = [], {}
    for j in m.joints:
        if j.name in absorbed:
            continue
        index[j.name] = len(items)
        x, y = j.at
        if j.name in blocks:
            pj = m.joint(blocks[j.name])
            index[pj.name] = len(items)
            block = pj.links[1]
            links = [_ground(m, pj.links[0])] + [_ground(m, lk) for lk in j.links if lk != block]
            kind = f"RP, A[{_fmt(math.degrees(math.atan2(pj.axis[1], pj.axis[0])))}]"
        elif j.kind is JointKind.P:
            links = [_ground(m, lk) for lk in j.links]
            kind = f"P, A[{_fmt(math.degrees(math.atan2(j.axis[1], j.axis[0])))}]"
        else:
            links, kind = [_ground(m, lk) for lk in j.links], "R"
        items.append(f"J[{kind}, color[Green], P[{_fmt(x)}, {_fmt(y)}], L[{', '.join(links)}]]")
    for pt in m.points:
        index[pt.name] = len(items)
        items.append(f"J[R, color[Green], P[{_fmt(pt.at[0])}, {_fmt(pt.at[1])}], L[{_ground(m, pt.link)}]]")
    return items, index


def _inputs(m: Mechanism, index: dict[str, int]) -> list[tuple[int, int]]:
    pairs = []
    for d in m.drivers:
        j = m.joint(d.joint)
        if j.kind is JointKind.P:
            pairs.append((index[j.name], index[j.name]))
            continue
        if m.frame not in d.links:
            raise InputError(explain(f"driver '{d.joint}'", expected="a link driven relative to the frame",
                                     got=f"relative to '{d.links[0]}'",
                                     hint="Pyslvs inputs are absolute link angles"))
        driven = d.links[1] if d.links[0] == m.frame else d.links[0]
        others = [index[o.name] for o in m.joints_of(driven) if o.name != j.name and o.name in index]
        others += [index[p.name] for p in m.points if p.link == driven]
        others = [i for i in others if i != index[j.name]]
        if not others:
            raise InputError(explain(f"driver '{d.joint}'", expected="a second joint on the driven link",
                                     got="none"))
        pairs.append((index[j.name], min(others)))
    return pairs


def pyslvs_losses(m: Mechanism) -> list[str]:
    """What a Pyslvs project cannot keep of ``m``, one phrase each (empty: nothing lost).

    Examples
    --------
    >>> from multiloop.inputs import load_mechanism
    >>> pyslvs_losses(load_mechanism("crank_slider_loaded"))[:2]
    ['masses and inertias (crank, rod, piston)', 'forces (gas)']
    """
    out = []
    heavy = [lk.name for lk in m.links if lk.mass is not None or lk.inertia is not None or lk.cg is not None]
    loads = [ld.name or f"on '{ld.link}'" for ld in m.loads]
    named = [j.name for j in m.joints if not re.fullmatch(r"P\d+(_slot)?", j.name)]
    points = [p.name for p in m.points if not re.fullmatch(r"P\d+", p.name)]
    rates = [d.joint for d in m.drivers if d.speed is not None or d.acceleration is not None]
    ranges = [d.joint for d in m.drivers if d.range is not None]
    reversed_ = [d.joint for d in m.drivers if m.frame is not None and d.links[1] == m.frame]
    for what, names in (("masses and inertias", heavy), ("forces", loads), ("joint names", named),
                        ("tracer point names", points), ("driver speeds and accelerations", rates),
                        ("driver ranges", ranges),
                        ("link colours", [lk.name for lk in m.links if lk.color])):
        if names:
            shown = ", ".join(n[:40] for n in names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
            out.append(f"{what} ({shown})")
    if m.gravity is not None:
        out.append("gravity")
    if m.frame is not None and m.frame != GROUND:
        out.append(f"the frame's name ('{m.frame[:40]}' becomes 'ground')")
    if reversed_:
        out.append(f"the input sense of driver(s) {', '.join(reversed_[:5])} (written frame-second, "
                   "exported frame-first: the input is negated)")
    return out


def expression_of(m: Mechanism) -> tuple[str, list[tuple[int, int]]]:
    """The Pyslvs expression of ``m`` and its ``[base, driver]`` input pairs."""
    items, index = _entries(m)
    return "M[" + ", ".join(items) + "]", _inputs(m, index)


def dumps_expression(m: Mechanism) -> str:
    """The bare Pyslvs expression (no inputs)."""
    return expression_of(m)[0] + "\n"


def with_pyslvs_names(m: Mechanism) -> Mechanism:
    """``m`` with every moving link whose name Pyslvs cannot read (e.g. the atlas's
    numbered links ``2``, ``3``) renamed ``L2``, ``L3``, … (a free name); the chain,
    joints and geometry unchanged."""
    from dataclasses import replace

    taken = set(m.link_names)
    new = {}
    for lk in m.link_names:
        if lk != m.frame and not _NAME.fullmatch(lk):
            base = "L" + re.sub(r"[^A-Za-z0-9_]", "_", lk)
            name, k = base, 1
            while name in taken:
                name, k = f"{base}_{k}", k + 1
            taken.add(name)
            new[lk] = name
    if not new:
        return m
    r = lambda lk: new.get(lk, lk)      # noqa: E731
    b = MechanismBuilder.from_mechanism(m)
    b.links = [replace(lk, name=r(lk.name)) for lk in b.links]
    b.joints = [replace(j, links=tuple(map(r, j.links))) for j in b.joints]
    b.drivers = [replace(d, links=tuple(map(r, d.links))) for d in b.drivers]
    b.points = [replace(p, link=r(p.link)) for p in b.points]
    b.loads = [replace(ld, link=r(ld.link)) for ld in b.loads]
    return b.build()


def dumps_pyslvs(m: Mechanism) -> str:
    """A ``.pyslvs`` project (YAML): a comment saying how coordinates are rounded
    (:data:`HEADER`), the ``mechanism`` expression and the ``input`` pairs."""
    import yaml  # noqa: PLC0415

    expr, inputs = expression_of(m)
    return HEADER + yaml.safe_dump({"mechanism": expr, "input": [list(p) for p in inputs]},
                                   sort_keys=False, width=1 << 16, default_flow_style=None)


def write_pyslvs(m: Mechanism, path: str | Path) -> None:
    """Write ``m`` as a ``.pyslvs`` project, or a bare expression for other suffixes."""
    p = Path(path)
    p.write_text(dumps_pyslvs(m) if p.suffix.lower() == ".pyslvs" else dumps_expression(m), encoding="utf-8")
