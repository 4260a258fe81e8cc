"""POSIX signals as interruptions: the one place the package installs signal handlers.

Ctrl-C (SIGINT), SIGTERM (``kill``, a service manager) and SIGHUP (a closed terminal) stop a
command with its story written: a run leaves its partial log and a metrics.json that says
``interrupted`` and names the signal (``manta_drake.run_folder``, ``manta_drake.simulate``),
an optimisation its state, and the command one line and the exit status 128 + the signal.

* ``interrupts_as_exceptions``: while inside, each of ``STOP_SIGNALS`` raises
  ``RunInterrupted`` (a KeyboardInterrupt naming the signal) and is noted in a list;
  ``interruption`` reads that list, so an exception that comes out of code a signal broke
  into (pydrake's import turns the interruption into an ImportError, a pybind11 call into a
  TypeError) is that interruption.
* ``signals_flagged``: while inside, a signal is only noted (the Simulator's step loop acts
  on it between steps; ``stop_if_signalled`` raises it).
* ``signals_deferred``: while inside, a signal waits; it is raised on exit (a file being
  written is written whole).

A signal the process ignores (``nohup`` ignores SIGHUP, a background job SIGINT) stays
ignored; handlers are installed only in the main thread (signals go there) and restored on
exit. This module uses the standard library only, so a command installs its handlers before
anything slow (pydrake) is imported.
"""

from __future__ import annotations

import contextlib
import signal
import threading

# The signals that stop a run with its story written: Ctrl-C, kill / a service manager, a
# closed terminal.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class RunInterrupted(KeyboardInterrupt):
    """The run was interrupted by a signal: Ctrl-C (SIGINT), SIGTERM or SIGHUP."""

    def __init__(self, signal_name: str = "SIGINT"):
        super().__init__(signal_name)
        self.signal_name = signal_name

    @property
    def reason(self) -> str:
        return (
            "interrupted (Ctrl-C)"
            if self.signal_name == "SIGINT"
            else f"terminated ({self.signal_name})"
        )

    @property
    def exit_status(self) -> int:
        """The shell's status of a process the signal ended: 128 + the signal's number."""
        return 128 + int(getattr(signal.Signals, self.signal_name, signal.SIGINT))


def interruption(error: BaseException, received=()) -> RunInterrupted | None:
    """The interruption behind ``error``, or None if it is none.

    ``error`` itself if a ``RunInterrupted``; Ctrl-C for a bare KeyboardInterrupt; for any
    other exception the first signal in ``received`` (the list ``interrupts_as_exceptions``
    fills): a signal's exception raised inside compiled code comes out as that code's error
    (pydrake's import raises ImportError "initialization failed", a pybind11 call a
    TypeError), and the run was interrupted all the same."""
    if isinstance(error, RunInterrupted):
        return error
    if isinstance(error, KeyboardInterrupt):
        return RunInterrupted("SIGINT")
    return RunInterrupted(received[0]) if received else None


def stop_if_signalled(received) -> None:
    """Raises the first signal in ``received`` as ``RunInterrupted``: one whose exception
    some code swallowed (an exception in a ``__del__`` is only printed) still stops the run."""
    if received:
        raise RunInterrupted(received[0])


def _install(handler) -> dict:
    """Installs ``handler`` for each of ``STOP_SIGNALS`` the process has not chosen to
    ignore (``nohup`` ignores SIGHUP, a background job SIGINT: they stay ignored) and whose
    handler Python can restore; returns the previous handlers."""
    previous = {}
    for sig in STOP_SIGNALS:
        old = signal.getsignal(sig)
        if old is signal.SIG_IGN or old is None:
            continue
        previous[sig] = signal.signal(sig, handler)
    return previous


def _restore(previous: dict) -> None:
    for sig, old in previous.items():
        signal.signal(sig, old)


@contextlib.contextmanager
def interrupts_as_exceptions():
    """While inside: Ctrl-C, SIGTERM and SIGHUP raise ``RunInterrupted`` (a
    KeyboardInterrupt naming the signal), so a run stopped by a service manager, ``kill`` or
    a closed terminal still writes its story, and each signal's name is appended to the
    yielded list (``interruption`` reads it). Only in the main thread (signals go there);
    restored on exit."""
    received: list = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handler(signum, frame):
        received.append(signal.Signals(signum).name)
        raise RunInterrupted(signal.Signals(signum).name)

    previous = _install(handler)
    try:
        yield received
    finally:
        _restore(previous)


@contextlib.contextmanager
def signals_flagged():
    """While inside, Ctrl-C, SIGTERM and SIGHUP only append their name to the yielded list.
    An exception raised by a handler in the middle of a pybind11 call (converting an argument,
    say) comes out as that call's TypeError, not as the interruption, so while the Simulator
    steps Python systems the signal is noted and acted on between steps (a monitor ends the
    step loop, the caller raises ``RunInterrupted``)."""
    pending: list = []
    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = _install(lambda signum, frame: pending.append(signal.Signals(signum).name))
    try:
        yield pending
    finally:
        _restore(previous)


@contextlib.contextmanager
def signals_deferred():
    """While inside, Ctrl-C, SIGTERM and SIGHUP are held; the first one is raised on exit as
    ``RunInterrupted`` (a story being written is written whole)."""
    with signals_flagged() as pending:
        yield
    stop_if_signalled(pending)
