"""Ctrl-C for the ``feeder`` command: one handler, and one remembered request every subcommand sees.

The request lives here, not in ``cli.main``: ``python -m feeder_cell.cli.main`` runs that module as
``__main__`` and a subcommand's ``from feeder_cell.cli.main import ...`` then loads a second copy of
it, whose flag the handler never set. A Ctrl-C swallowed in an import lock's callback was then lost
for the whole run (a CI run's `throw-design` went on for 30 s after it).
"""

from __future__ import annotations

import signal

_requested = {"value": False}


def _on_ctrl_c(_number: int, _frame: object) -> None:
    _requested["value"] = True
    raise KeyboardInterrupt


def _remember_ctrl_c(_number: int, _frame: object) -> None:
    _requested["value"] = True


def remember_ctrl_c() -> None:
    """Make SIGINT only remembered, from the first line of ``cli.main`` until ``main`` takes it.

    A KeyboardInterrupt raised into the imports of ``cli.main`` itself came out as a traceback and the
    status -2 (a CI run's Ctrl-C 0.3 s into `throw-design`, on a loaded machine); remembered, it ends the
    command in ``main`` as any other Ctrl-C does: the "interrupted" line and 130.
    """
    signal.signal(signal.SIGINT, _remember_ctrl_c)


def take_ctrl_c() -> None:
    """Make SIGINT raise KeyboardInterrupt here, whatever disposition the command inherited, and remember it.

    A shell without job control starts a background command (`cmd &`, a CI script's job) with SIGINT
    ignored, and Python then installs no handler of its own: `kill -INT` of a long `throw-design` was
    lost, and it ran to its end with exit 0. A command that documents Ctrl-C (one line, exit 130) takes
    it explicitly, as rclpy's nodes and `ros2 bag` do. Python swallows an exception raised inside a
    finalizer or an import lock's callback ("Exception ignored in"), so the request is also kept:
    long work looks at it between items (``check_ctrl_c``). Subcommands that run a node install their
    own handlers on top (ros_session.with_node).
    """
    signal.signal(signal.SIGINT, _on_ctrl_c)


def ctrl_c_requested() -> bool:
    """Whether Ctrl-C came in this run, even if its KeyboardInterrupt was swallowed or wrapped.

    Python also wraps it: raised while a class body's ``__set_name__`` runs (a dataclass field, in an
    import), it comes out as a RuntimeError (make stress: a Ctrl-C 1.2 s into `throw-design` ended it
    with that traceback and 1). Once Ctrl-C came, the command ends as interrupted whatever it raised.
    """
    return _requested["value"]


def check_ctrl_c() -> None:
    """Raise KeyboardInterrupt if Ctrl-C came, even if its first KeyboardInterrupt was swallowed."""
    if ctrl_c_requested():
        raise KeyboardInterrupt
