"""The console scripts of the nodes: stop signals are held from the script's first line.

A node's module imports rclpy, numpy and its mechanics before its ``main`` can take SIGINT and SIGTERM
(``node_kit.runner.StopRequest``): 0.6 to 1.5 s on this machine, in which Python's own handler raised
KeyboardInterrupt inside an import (a traceback, exit -2). Each node's console script is therefore
``lazy_main(module)``: it holds the stop signals (stdlib only, within milliseconds of the start), then
imports the module; ``StopRequest.install`` takes over and honours a signal held meanwhile. Only the
scripts do this: importing a node module (tests, docs) installs nothing.
"""

from __future__ import annotations

import importlib
import importlib.util
import signal
from typing import Callable

__all__ = ["STOP_SIGNALS", "held_signal", "hold_stop_signals", "lazy_main", "node_main"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_held: list[int] = []


def _hold(number: int, _frame: object) -> None:
    _held.append(number)


def hold_stop_signals() -> None:
    """Hold SIGINT and SIGTERM from now on: a signal is kept (held_signal) and raises nothing."""
    for number in STOP_SIGNALS:
        signal.signal(number, _hold)


def held_signal() -> int | None:
    """Return the first stop signal held since hold_stop_signals, if any."""
    return _held[0] if _held else None


def lazy_main(module: str) -> Callable[[], None]:
    """Return a console script's entry: hold the stop signals, import ``module``, run its ``main()``."""

    def main() -> None:
        hold_stop_signals()
        importlib.import_module(module).main()

    main.__doc__ = f"Run {module}.main() with the stop signals held from the start."
    return main


MAIN_SUFFIX = "_main"


def node_main(package: str, attribute: str) -> Callable[[], None]:
    """Return ``PACKAGE.nodes``'s console-script entry ``NAME_main``: ``lazy_main`` of the module ``NAME``.

    A node package's ``__init__`` answers its module ``__getattr__`` (PEP 562) with this, so every node
    module there is an executable of its own name with no line of its own (its setup.py lists the
    directory). Finding the module's spec does not import it: the signals are still held first.
    """
    name = attribute.removesuffix(MAIN_SUFFIX)
    if attribute.endswith(MAIN_SUFFIX) and name.isidentifier() and not name.startswith("_"):
        if importlib.util.find_spec(f"{package}.{name}") is not None:
            return lazy_main(f"{package}.{name}")
    raise AttributeError(f"module {package!r} has no attribute {attribute!r}")
