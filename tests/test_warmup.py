"""The install's warm-up (``python -m multiloop.warmup``): every compiled route run once."""
from __future__ import annotations

from multiloop import warmup
from multiloop.kin import kernel


def test_the_warm_up_takes_every_compiled_route(capsys):
    assert warmup.main() == 0
    out = capsys.readouterr().out
    if kernel.load() is None:
        assert "nothing to compile" in out
        return
    for what in ("solve (compiled plan)", "free timing matched", "free timing searched", "prescribed timing",
                 "triad six-bar"):
        assert what in out
    from multiloop.kin import _kernel_nb
    assert _kernel_nb.solve_motion.signatures            # solve's lean route (a whole turn, its chart cached)
