"""Bad input: :class:`InputError`, the one exception of every layer for a value refused (a
:class:`ValueError` that names the argument). Imports nothing, so that the command line can
raise it without loading the numerics (decision 0007-start-up).
"""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Bad input to a public function: a :class:`ValueError` naming the argument.

    Parameters
    ----------
    argument : str
        The argument's name as the function spells it (e.g. ``'depth'``, ``'rgb'``).
    reason : str
        Why the value is refused.

    Examples
    --------
    >>> from forward.errors import InputError
    >>> from forward.validate import scalar
    >>> try:
    ...     scalar("depth", -1.0)
    ... except InputError as exc:
    ...     print(exc.argument, "|", exc)
    depth | depth: must be >= 0, got -1.0
    """

    def __init__(self, argument: str, reason: str):
        self.argument, self.reason = str(argument), str(reason)
        super().__init__(f"{self.argument}: {self.reason}")

    def __reduce__(self):  # picklable across processes (Dask, multiprocessing)
        return type(self), (self.argument, self.reason)
