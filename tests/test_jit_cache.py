"""numba's disk cache kept fresh across files (kin._jit_cache): numba keys a module's
cached machine code on that module's own file, so a compiled module whose code inlines
another file's registers it (``depends_on``); an edit there must rebuild the cache in the
next process, and the process after loads the new code from it."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("numba")

_MODULE = textwrap.dedent('''
    import numba
    from numba.extending import register_jitable
    from multiloop.kin._jit_cache import depends_on
    from . import dep
    {register}
    _value = register_jitable(dep.value)


    @numba.njit(cache=True)
    def f():
        return _value()
''')


def _package(tmp_path, register: bool):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "dep.py").write_text("def value():\n    return 1.0\n")
    (pkg / "mod_nb.py").write_text(_MODULE.format(register="depends_on(__file__, [dep.__file__])" if register else ""))
    code = ("from pkg import mod_nb as m; s = m.f.stats; "
            "print(m.f(), sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])])

    def run():
        out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True,
                             check=True)
        return out.stdout.split()

    return pkg, run


def test_an_edit_of_a_registered_source_rebuilds_the_cache(tmp_path):
    pkg, run = _package(tmp_path, register=True)
    assert run() == ["1.0", "0", "1"]                   # compiled, written to the cache
    assert run() == ["1.0", "1", "0"]                   # loaded from it
    (pkg / "dep.py").write_text("def value():\n    return 2.0\n")      # (the same size)
    assert run() == ["2.0", "0", "1"]                   # the stale entry refused: compiled anew
    assert run() == ["2.0", "1", "0"]


def test_without_registering_numba_keeps_the_stale_code(tmp_path):
    """Why: numba alone serves the old machine code after an edit of an inlined file."""
    pkg, run = _package(tmp_path, register=False)
    assert run() == ["1.0", "0", "1"]
    (pkg / "dep.py").write_text("def value():\n    return 2.0\n")
    assert run()[0] == "1.0"


def test_the_stamp_follows_the_sources_transitively(tmp_path):
    from multiloop.kin._jit_cache import depends_on, source_stamp
    a, b, c = (tmp_path / n for n in ("a.py", "b.py", "c.py"))
    for f in (a, b, c):
        f.write_text(f"# {f.name}\n")
    depends_on(str(b), [str(c)])
    depends_on(str(a), [str(b)])
    before = source_stamp(str(a))
    c.write_text("# c, edited\n")
    assert source_stamp(str(a)) != before              # (c is a's source through b)
