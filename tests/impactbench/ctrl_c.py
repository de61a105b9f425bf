"""Starting a command that a test will interrupt with SIGINT, as a terminal's Ctrl-C does.

A child inherits an *ignored* SIGINT across fork and exec (POSIX), and a shell ignores SIGINT in
the commands it starts in the background (``cmd &`` without job control) — so under
``bash -c 'pytest … &'`` (or any runner that ignores SIGINT) the command would never see the
Ctrl-C the test sends, and Python, which keeps an inherited SIG_IGN, would not turn it into
KeyboardInterrupt. A *caught* signal, by contrast, is reset to its default action by exec. So
while the child starts, this process catches SIGINT with Python's own handler: the child then
starts with SIGINT at its default and Python installs its KeyboardInterrupt handler, whatever
this process inherited.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


@contextlib.contextmanager
def interruptible_children() -> Iterator[None]:
    """Processes started inside take SIGINT as KeyboardInterrupt (module doc). Main thread
    only (Python sets signal handlers there); the previous handler is restored after."""
    if threading.current_thread() is not threading.main_thread():
        raise RuntimeError("interruptible_children: call it from the main thread")
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        if previous is not None:   # None: a handler not set from Python; leave ours
            signal.signal(signal.SIGINT, previous)
