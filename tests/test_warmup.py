"""The install's warm-up (``python -m multiloop.warmup``): every compiled route run once."""
from __future__ import annotations

from multiloop import warmup
from multiloop.kin import kernel


def test_the_warm_up_takes_every_compiled_route(capsys, monkeypatch):
    from multiloop.kin import solve as solve_mod
    lean, compiled_motion = [], solve_mod._compiled_motion

    def recorded(*a, **k):
        state = compiled_motion(*a, **k)
        lean.append(state is not None)
        return state
    monkeypatch.setattr(solve_mod, "_compiled_motion", recorded)
    assert warmup.main() == 0
    out = capsys.readouterr().out
    if kernel.load() is None:
        assert "nothing to compile" in out
        return
    for what in ("solve (compiled plan)", "free timing matched", "free timing searched", "prescribed timing",
                 "triad six-bar"):
        assert what in out
    assert any(lean)                      # solve's lean route taken (a whole turn, its chart cached)
