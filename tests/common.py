"""Shared test helpers: random chains (hypothesis strategies) and relabelling; small
atlases; ``multiloop serve`` in a subprocess."""
from __future__ import annotations

import random
import re
import socket
import subprocess
import sys
import tempfile

import numpy as np

from hypothesis import strategies as st

from multiloop.topo.model import Mechanism, MechanismBuilder, chain_from_joint_lists


def random_joint_lists(rng: random.Random, n_links: int, extra: int, p_multiple: float) -> list[list[str]]:
    """A connected chain whose links all have >= 2 joints: a Hamiltonian cycle over the
    links plus ``extra`` joints; with probability ``p_multiple`` a new joint is a pin on
    three (rarely four) links."""
    names = [f"l{i}" for i in range(n_links)]
    rng.shuffle(names)
    joints = [[names[i], names[(i + 1) % n_links]] for i in range(n_links)]
    for _ in range(extra):
        k = 2
        if rng.random() < p_multiple:
            k = 3 if rng.random() < 0.8 or n_links < 4 else 4
        joints.append(rng.sample(names, min(k, n_links)))
    # occasionally merge two existing simple joints that share a link into one pin
    if p_multiple and rng.random() < p_multiple and len(joints) > 3:
        a = joints[0]
        for b in joints[1:]:
            shared = set(a) & set(b)
            if shared and len(set(a) | set(b)) == 3 and \
                    sum(1 for j in joints if shared <= set(j)) >= 3:  # shared link keeps >= 2 joints
                joints.remove(b)
                joints.remove(a)
                joints.append(sorted(set(a) | set(b)))
                break
    return joints


@st.composite
def chains(draw, min_links: int = 3, max_links: int = 9, multiple: bool = True):
    n = draw(st.integers(min_links, max_links))
    extra = draw(st.integers(0, n // 2 + 2))
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = random.Random(seed)
    return chain_from_joint_lists(random_joint_lists(rng, n, extra, 0.4 if multiple else 0.0))


def relabel(m: Mechanism, seed: int) -> Mechanism:
    """A copy with link names permuted, joints renamed and reordered."""
    rng = random.Random(seed)
    new = [f"x{i}" for i in range(m.n_links)]
    rng.shuffle(new)
    link_map = dict(zip(m.link_names, new))
    joint_map = {j.name: f"q{k}" for k, j in enumerate(m.joints)}
    order = list(range(m.n_joints))
    rng.shuffle(order)
    return m.relabelled(link_map, joint_map, order)


# A bare chain in the the file format (README) short form (a triple pin b-c-d).
BARE = 'joints = [["a", "b"], ["b", "c", "d"], ["c", "e"], ["d", "e"], ["e", "a"]]\n'

# A parallelogram with a redundant link (c3): F = 0 by formula, but it moves (the structural numbers (README)).
PARALLELOGRAM = """
name = "parallelogram with a redundant link"
[[link]]
name = "frame"
frame = true
[[joint]]
name = "A"
links = ["frame", "c1"]
at = [0.0, 0.0]
[[joint]]
name = "B"
links = ["c1", "cp"]
at = [0.0, 1.0]
[[joint]]
name = "C"
links = ["cp", "c2"]
at = [2.0, 1.0]
[[joint]]
name = "D"
links = ["c2", "frame"]
at = [2.0, 0.0]
[[joint]]
name = "E"
links = ["frame", "c3"]
at = [1.0, 0.0]
[[joint]]
name = "F"
links = ["c3", "cp"]
at = [1.0, 1.0]
[[driver]]
joint = "A"
"""


def six_bar_chain_atlas(db):
    """An atlas at ``db`` with the chains of six links and one degree of freedom (the
    atlas the web pages browse)."""
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.synthesis import SynthesisOptions

    with Atlas(db) as a:
        a.build(SynthesisOptions(6, 1), progress=False)
    return db


def four_bar_curve_atlas(db):
    """An atlas at ``db`` with the four-bar's mechanisms and 6 curve realisations each
    (small and quick: the tests of the curve index and of synthesis without a start)."""
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.curve_atlas import build_curves
    from multiloop.catalogue.inversions import build_mechanisms
    from multiloop.catalogue.synthesis import SynthesisOptions

    with Atlas(db) as atlas:
        opts = SynthesisOptions(4, 1, simple_joints=True)
        atlas.build(opts, progress=False, loops=False)
        build_mechanisms(atlas, opts)
        build_curves(atlas, opts, 6)
    return db


def child_pids(pid: int) -> set[int]:
    """The processes whose parent is ``pid`` (``ps``)."""
    import subprocess
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return {int(x) for x in out.split()}


def alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie is dead)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except FileNotFoundError:
        return False


def tasks_done(db) -> int:
    """Tasks an atlas build has stored so far (0 while the file is being created)."""
    from multiloop.catalogue.atlas import Atlas
    if not db.exists():
        return 0
    try:
        with Atlas(db) as a:
            return a.con.execute("SELECT count(*) FROM tasks WHERE status='done'").fetchone()[0]
    except Exception:  # noqa: BLE001 - the file may be mid-creation
        return 0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_serve(*args: str):
    """``multiloop serve ARGS`` on a free port: (the address it printed, with its token;
    the process, its stderr in ``proc.err``, a file: a pipe nobody reads could fill)."""
    port = free_port()
    err = tempfile.TemporaryFile("w+")
    proc = subprocess.Popen([sys.executable, "-m", "multiloop", "serve", "--port", str(port), *args],
                            stdout=subprocess.PIPE, stderr=err, text=True)
    proc.err = err
    line = proc.stdout.readline()
    url = re.search(rf"http://127\.0\.0\.1:{port}/\S*", line)
    assert url, line + stderr_of(proc)
    return url.group(0), proc


def stderr_of(proc) -> str:
    proc.err.seek(0)
    return proc.err.read()


def stop(proc) -> None:
    proc.terminate()
    proc.wait(timeout=20)
    proc.stdout.close()
    proc.err.close()


#: a number and its unit in a verdict line (°, rad, m, mm or in): the page's verdict
#: in other units has the words of ``check --json``'s and these numbers scaled
QUANTITY = r"([-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?)(°| rad| mm| m| in)(?!\w)"


# -- the compiled design route against the NumPy route (test_synthesis_kernel, test_triad_kernel)
def design_population(m, D, rel, seed):
    """D designs of ``m``: its start and designs moved by ``rel`` × its size (normal)."""
    from multiloop.catalogue.dimensional import design_space
    space = design_space(m, [p.name for p in m.points])
    X = space.x0 + rel * m.size * np.random.default_rng(seed).standard_normal((D, space.size))
    X[0] = space.x0
    return space.names, X


def both_routes(m, cols, X, inputs, outputs=None):
    """``solve_designs`` by the NumPy route and by the compiled one."""
    from multiloop.kin import kernel
    from multiloop.kin.design import solve_designs
    with kernel.using("off"):
        a = solve_designs(m, cols, X, inputs, outputs=outputs)
    with kernel.using("on"):
        b = solve_designs(m, cols, X, inputs, outputs=outputs)
    return a, b


def routes_agree(m, a, b):
    """The same ``ok``, the same NaN pattern, poses and angles within 1e-12 of the size."""
    from multiloop.kin.solve import plan_of
    size = plan_of(m).size
    np.testing.assert_array_equal(a.ok, b.ok)
    a.th, b.th                                  # every pending angle row computed
    Ta, Tb = a.store.T, b.store.T
    np.testing.assert_array_equal(np.isnan(Ta), np.isnan(Tb))
    scale = np.array([size, size, 1.0])[None, :, None, None]
    assert np.nanmax(np.abs(Ta - Tb) / scale, initial=0.0) <= 1e-12
    np.testing.assert_array_equal(np.isnan(a.th), np.isnan(b.th))
    assert np.nanmax(np.abs(a.th - b.th), initial=0.0) <= 1e-12


def slide_driven() -> Mechanism:
    """A slider (P driver on the frame) that moves an RRR dyad."""
    b = MechanismBuilder(name="slide-driven")
    b.add_link("f", frame=True)
    b.add_joint("S", "P", ("f", "s"), at=(0, 0), axis=(1, 0))
    b.add_joint("A", "R", ("s", "r"), at=(0, 0))
    b.add_joint("B", "R", ("r", "k"), at=(0.5, 0.8))
    b.add_joint("C", "R", ("k", "f"), at=(1.0, 0.0))
    b.add_driver("S")
    return b.build()
