"""The scalar helpers of :mod:`kin.groups.base` (:func:`~kin.groups.base.scalar`)
made callable from numba's code, once per process: by the plan kernel
(:mod:`kin._kernel_nb`) and by the compiled steps kept in modules of their own (the
triad's tracker, :mod:`kin.groups._triad_nb`)."""
from __future__ import annotations

from numba.extending import register_jitable

from .groups.base import INLINE_HELPERS, SCALAR_HELPERS

__all__ = ["JIT"]

#: the options of every compiled function of the kernels
JIT = dict(cache=True, error_model="numpy", nogil=True)

for _helper in SCALAR_HELPERS:
    register_jitable(**JIT, **({"inline": "always"} if _helper in INLINE_HELPERS else {}))(_helper)
del _helper
