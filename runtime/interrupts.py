"""Ctrl-C (SIGINT) and SIGTERM: the exceptions they raise in piezotip and the handlers that raise them.

Both signals stop what piezotip is doing as Ctrl-C does: a run keeps its recording so far and
writes a summary marked ``"interrupted": true`` (:mod:`piezotip.analysis.runner`), a sweep keeps
its journal, and the signal's exception leaves the call, so a script's loop over
:func:`piezotip.run` or :func:`piezotip.sweep` stops there.

What leaves a call of the Python API (:func:`caller_error`):

- after SIGINT, a ``KeyboardInterrupt`` itself, what Ctrl-C raises anywhere in Python: uncaught,
  the script ends as any Python script ends on Ctrl-C (its traceback, status 130 by the shell's count);
- after SIGTERM, :class:`Terminated`: a ``KeyboardInterrupt`` too, so that a script's ``except
  KeyboardInterrupt`` catches both, and a ``SystemExit`` whose code is 143 (128 + SIGTERM), so
  that uncaught it ends the script with status 143 and no traceback, as the command line does
  (an uncaught exception of another kind would end it with status 1 and a traceback, which a
  batch system reads as a crash).

Either carries ``signum`` and ``result``: the partial :class:`piezotip.Result` (its files are
in ``out`` when one was given) or None when nothing ran.  (Not :class:`RunInterrupted` for
SIGINT: Python ends a script the Ctrl-C way only for an uncaught ``KeyboardInterrupt`` itself;
a subclass ends it with status 1.)

Inside piezotip a signal is raised as :class:`RunInterrupted` (:func:`interruption`), which the
loop and the command line catch as Ctrl-C.  Each handler also notes the signal (:func:`note`)
for the enclosing :func:`raised` block, so that no outcome depends on where the signal lands:
an error a library makes of the exception (an import it cut short) or a library that swallows
it is still the interruption (:func:`signal_in`, :func:`noted`).  This module imports only the
standard library: the command line installs its handlers before it imports anything heavy, so a
Ctrl-C in its first tenths of a second is an interruption like any later one.
"""

from __future__ import annotations

import contextlib
import functools
import signal
import sys
import threading


class RunInterrupted(KeyboardInterrupt):
    """A signal stopped the work: ``signum`` (SIGINT or SIGTERM).  A KeyboardInterrupt, so whatever
    catches Ctrl-C (the loop, the command line, a user's script) catches it."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    def __reduce__(self):
        return type(self), (self.signum,)

    @property
    def exit_status(self) -> int:
        """The process's exit status by the shell's convention: 128 + the signal's number."""
        return 128 + self.signum


class Terminated(RunInterrupted, SystemExit):
    """SIGTERM's exception: a KeyboardInterrupt (caught as Ctrl-C is) and a SystemExit with code
    143 (uncaught, the interpreter exits with that status and prints no traceback)."""

    def __init__(self, signum: int = signal.SIGTERM) -> None:
        super().__init__(signum)
        self.code = self.exit_status  # SystemExit's: what an uncaught one exits with


def interruption(signum: int) -> RunInterrupted:
    """The exception piezotip raises for signal ``signum``: :class:`Terminated` for SIGTERM,
    :class:`RunInterrupted` for the others (SIGINT)."""
    return Terminated(signum) if signum == signal.SIGTERM else RunInterrupted(signum)


def raise_interruption(signum: int, frame) -> None:
    """The handler of SIGINT and SIGTERM while a command or an API call runs (:func:`raised`)."""
    note(signum)
    raise interruption(signum)


#: The signals noted in the innermost :func:`raised` block, in order (None outside one).
_noted: list[int] | None = None


def note(signum: int) -> None:
    """Remember that ``signum`` came (a handler calls this before it raises or holds it): an
    error a library makes of the exception, or the library's silence, cannot then hide it."""
    if _noted is not None:
        _noted.append(int(signum))


def noted() -> int | None:
    """The first signal noted in the innermost :func:`raised` block, or None (always in a thread
    but the main one: no signal's handler runs there, so none is behind its errors)."""
    return _noted[0] if _noted and in_main_thread() else None


#: Each signal with the handlers piezotip may take over: Python's own, and piezotip's
#: (:func:`raise_interruption`).  A handler a program set itself is left alone, and so is an
#: ignored signal (a shell's background job starts with SIGINT ignored).
_OURS = {
    signal.SIGINT: (signal.default_int_handler, raise_interruption),
    signal.SIGTERM: (signal.SIG_DFL, raise_interruption),
}

#: The signals handled.
SIGNALS = tuple(_OURS)


def replaceable(signum: int, handler) -> bool:
    """Whether ``handler``, the one in place for ``signum``, is Python's own or piezotip's."""
    return any(handler is ours for ours in _OURS.get(signum, ()))


def in_main_thread() -> bool:
    """Whether this is the main thread, the only one where Python runs signal handlers."""
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def raised(keep_held: bool = False):
    """Inside, SIGINT and SIGTERM raise :func:`interruption` (main thread only, where their
    handlers are Python's own); on leaving, the handlers are as they were, but with
    ``keep_held`` those :func:`hold` set, which then last until the process ends.  SIGTERM's
    default would end the process at once, without the summary of the run it cut short."""
    global _noted
    if not in_main_thread():  # signals are the main thread's alone
        yield
        return
    previous, outer, _noted, hook = {}, _noted, [], sys.unraisablehook
    for signum in SIGNALS:
        if replaceable(signum, signal.getsignal(signum)):
            previous[signum] = signal.signal(signum, raise_interruption)
    sys.unraisablehook = functools.partial(_unraisable, hook)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            if not (keep_held and signal.getsignal(signum) is signal.SIG_IGN):
                signal.signal(signum, handler)
        sys.unraisablehook = hook
        _noted = outer


def _unraisable(hook, unraisable) -> None:
    """``sys.unraisablehook`` inside :func:`raised`: a signal's exception raised where Python
    cannot pass it on (a weakref callback of the import system, a ``__del__``) is noted already
    and ends the work as "interrupted"; Python's "Exception ignored in ..." and its traceback
    would only add lines to that.  Anything else goes to ``hook``, the one in place before."""
    if not isinstance(unraisable.exc_value, RunInterrupted):
        hook(unraisable)


def hold() -> None:
    """Inside :func:`raised`, once a signal has stopped the work: any later SIGINT or SIGTERM is
    ignored until the block ends (the first decided the outcome; a second cannot cut short the
    line and the status that report it).  Ignored, not handled: a handler of Python's would be
    reset to the default as the interpreter ends, and a signal then would kill the process."""
    if in_main_thread():
        for signum in SIGNALS:
            if signal.getsignal(signum) is raise_interruption:
                signal.signal(signum, signal.SIG_IGN)


def signal_in(err: BaseException | None) -> int | None:
    """The signal behind ``err``: its own (a :class:`RunInterrupted`), SIGINT for any other
    KeyboardInterrupt, or that of an exception it was raised from or while handling (a C
    extension whose import a Ctrl-C cut short raises ``ImportError: initialization failed``
    from the KeyboardInterrupt); else the first signal :func:`noted` (numpy's import cut short
    can lose the KeyboardInterrupt: ``PyCapsule_Import could not import module "datetime"``);
    None when no signal is behind it."""
    seen = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, RunInterrupted):
            return err.signum
        if isinstance(err, KeyboardInterrupt):
            return int(signal.SIGINT)
        err = err.__cause__ or err.__context__
    return noted()


def caller_error(signum: int, message: str, result=None) -> BaseException:
    """What the Python API raises after ``signum`` stopped it (the module's notes): a
    KeyboardInterrupt for SIGINT, :class:`Terminated` for SIGTERM (``message`` in a note), with
    ``message`` (what a traceback shows), ``signum`` and ``result``."""
    if signum == signal.SIGTERM:
        err = Terminated(signum)
        err.add_note(message)
    else:
        err = KeyboardInterrupt(message)
    err.signum = int(signum)
    err.result = result
    return err


__all__ = [
    "SIGNALS",
    "RunInterrupted",
    "Terminated",
    "caller_error",
    "hold",
    "in_main_thread",
    "interruption",
    "note",
    "noted",
    "raise_interruption",
    "raised",
    "replaceable",
    "signal_in",
]
