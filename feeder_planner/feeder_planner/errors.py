"""Error classes of the feeder packages."""

from __future__ import annotations


class FeederError(Exception):
    """Base class of every error the feeder packages raise on purpose."""


class InputError(FeederError):
    """Bad user input: a file, a flag, a parameter or a service request field.

    The message always names where the bad value came from (``source``), which
    field (``field``, a dotted path such as ``bodies[1].boxes[0].max``) and what is
    wrong, so that the CLI can print it as one line and a node can return it.
    """

    def __init__(self, field: str, problem: str, source: str | None = None) -> None:
        self.field = field
        self.problem = problem
        self.source = source
        super().__init__(self._render())

    def _render(self) -> str:
        where = f"{self.source}: " if self.source else ""
        return f"{where}{self.field}: {self.problem}"

    def with_source(self, source: str) -> InputError:
        """Return the same error attributed to ``source`` (a file path or request name)."""
        return InputError(self.field, self.problem, source)


class SolverError(FeederError):
    """A numerical method could not certify its result; nothing uncertified is returned."""
