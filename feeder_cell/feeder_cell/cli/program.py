"""The ``feeder`` console script's entry point: Ctrl-C is remembered before anything else is imported.

``cli.main`` imports the parser's and the errors' modules first; a Ctrl-C that came meanwhile was raised
into an import, a traceback and the status -2. Imported only by the console script (importing ``cli.main``
itself, as the tests do, changes no signal disposition); ``python -m feeder_cell.cli.main`` does the same
at the top of that module.
"""

from __future__ import annotations

from feeder_cell.cli.ctrl_c import remember_ctrl_c

remember_ctrl_c()

from feeder_cell.cli.main import run  # noqa: E402 - after the handler, on purpose

__all__ = ["run"]
