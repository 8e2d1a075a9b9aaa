"""SIGINT and SIGTERM as one exception, :class:`Interrupted`, held back where a stop would tear a file.

:func:`install` (the console script's first statement, before any heavy import) routes both signals to a
handler that raises :class:`Interrupted` (a ``KeyboardInterrupt``, so every ``except KeyboardInterrupt``
clean-up also runs on SIGTERM) wherever the program is, except inside :func:`deferred`: there the signal
is noted and raised when the block ends, or earlier at a :func:`checkpoint` (a co-simulation checks
between macro steps: a signal raised inside an FMU call would come back as an FMU error). Once raised,
further signals are noted but do not interrupt the clean-up (the partial summary, the one line); a third
one ends the process at once with the same exit code.

Exit codes (the shell's convention, 128 + the signal's number): 130 for SIGINT, 143 for SIGTERM. A signal
after the command has finished (during the interpreter's teardown) is ignored: :func:`ignore_at_exit`.
"""

from __future__ import annotations

import atexit
import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM)
IMMEDIATE_AFTER = 3
"""Signals after which the process ends at once, clean-up or not."""


class Interrupted(KeyboardInterrupt):
    """The process received SIGINT or SIGTERM (``signum``); ``exit_code`` is 128 + the signal's number."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        self.name = signal.Signals(self.signum).name
        self.exit_code = 128 + self.signum
        super().__init__(self.name)


class _State:
    depth = 0  # nesting of deferred() blocks
    pending: int | None = None  # a signal received inside one, not yet raised
    received = 0  # signals received since the first raise
    installed = False


def _handler(signum: int, _frame) -> None:
    if _State.received:
        _State.received += 1
        if _State.received >= IMMEDIATE_AFTER:
            os._exit(128 + signum)
        return
    if _State.depth:
        if _State.pending is None:
            _State.pending = signum
        return
    _State.received = 1
    raise Interrupted(signum)


def install() -> bool:
    """Route SIGINT and SIGTERM to :class:`Interrupted` (main thread only; False elsewhere)."""
    if threading.current_thread() is not threading.main_thread():
        return False
    for signum in SIGNALS:
        signal.signal(signum, _handler)
    _State.installed = True
    return True


def installed() -> bool:
    """Whether :func:`install` ran in this process."""
    return _State.installed


def ignore_at_exit() -> None:
    """Ignore SIGINT and SIGTERM once the interpreter exits (the console script registers this before its
    command imports anything, so it runs after the exit handlers those imports register). Python gives a
    signal it handled back its default action before it destroys its modules, so one arriving in those
    last tenths of a second would kill a process whose files are whole and whose exit code is set (exit -2,
    no message); an ignored signal stays ignored."""
    atexit.register(_ignore_signals)


def _ignore_signals() -> None:
    for signum in SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def checkpoint() -> None:
    """Raise :class:`Interrupted` now if a signal was held back (call it where stopping is safe)."""
    signum = _State.pending
    if signum is not None:
        _State.pending = None
        _State.received = 1
        raise Interrupted(signum)


@contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for the block; one received meanwhile is raised when the block ends
    (unless the block is already ending with an exception, which then stands and is reported)."""
    _State.depth += 1
    try:
        yield
    finally:
        _State.depth -= 1
    if _State.depth == 0:
        checkpoint()


@contextmanager
def held() -> Iterator[None]:
    """:func:`deferred` for a block that calls :func:`checkpoint` where it may stop (a co-simulation, between
    macro steps); the handlers are installed for the block when the console script did not install them
    (a library caller), and the caller's restored after it."""
    previous = None
    # the handlers actually in place, not the flag: a caller may have replaced them since install()
    in_place = all(signal.getsignal(signum) is _handler for signum in SIGNALS)
    if not in_place and threading.current_thread() is threading.main_thread():
        previous = {signum: signal.getsignal(signum) for signum in SIGNALS}
        install()
    try:
        with deferred():
            yield
    finally:
        if previous is not None:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
            _State.installed = False


def exit_code(error: BaseException) -> int:
    """The exit code of a stop: 130 for SIGINT (or a plain KeyboardInterrupt), 143 for SIGTERM."""
    return error.exit_code if isinstance(error, Interrupted) else 128 + signal.SIGINT


def signal_name(error: BaseException) -> str:
    """SIGINT or SIGTERM: which signal stopped the process."""
    return error.name if isinstance(error, Interrupted) else "SIGINT"


def reset_for_tests() -> None:
    """Forget held and received signals (a test that runs several commands in one process)."""
    _State.depth, _State.pending, _State.received = 0, None, 0


__all__ = ["Interrupted", "checkpoint", "deferred", "exit_code", "ignore_at_exit", "install", "signal_name"]
