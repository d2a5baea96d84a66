"""Shared behaviour of batch results: a ``status`` array with ``"ok"`` or a reason."""
from __future__ import annotations

import numpy as np

__all__ = ["BatchStatus"]


class BatchStatus:
    """Mixin for frozen batch results that carry ``status`` (and possibly ``inputs``).

    ``ok`` is the mask of positions that succeeded, ``success`` says all did, and
    ``message`` names how many failed and the first failing input with its reason.
    """

    __slots__ = ()

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the positions that succeeded."""
        return np.asarray(self.status) == "ok"

    @property
    def success(self) -> bool:
        return bool(np.all(self.ok))

    @property
    def message(self) -> str:
        """``"ok"``, or the count of failures and the first failing input and reason."""
        ok = self.ok
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            return "ok"
        n = int(bad[0])
        inputs = getattr(self, "inputs", None)
        where = f"input {np.asarray(inputs)[n].tolist()}" if inputs is not None else f"position #{n}"
        return f"{bad.size} of {ok.size} positions failed; first at {where}: {self.status[n]}"
