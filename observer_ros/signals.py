# Copyright 2026 observer_ros contributors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
How every executable stops on SIGINT and SIGTERM: once, cleanly, whatever follows.

``ros2 launch`` on Ctrl-C delivers two SIGINTs nearly at once (the terminal's to the process
group, then launch's own) and escalates to SIGTERM. rclpy's default handling raises
``KeyboardInterrupt`` wherever the main thread is, which aborts the process when that is a
callback inside the EventsExecutor's C++ frames ("terminate called ... KeyboardInterrupt"),
and it shuts the context down from another thread while callbacks still run. The nodes
therefore call ``rclpy.init`` without rclpy's handlers and stop through
:class:`StopSignals`: the first SIGINT or SIGTERM only records a stop request (or, for
loops made of Python code only, raises ``KeyboardInterrupt`` once); from that moment the
process ignores both signals, so a second one cannot interrupt the clean-up.

The nodes exit 0 on a stop signal, as ROS 2 nodes do. The offline tools (``replay``,
``design_observer``, see :func:`stops_on_signal`) print one line and exit with the shell's
``128 + signal number``: 130 for SIGINT, 143 for SIGTERM.
"""

import ctypes
import functools
import signal
import sys
from types import FrameType
from typing import Callable, Dict, Optional, Union

#: The signals that stop an executable; SIGTERM means the same as SIGINT.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

_Handler = Union[Callable[[int, Optional[FrameType]], object], int, None]


def ignore_stop_signals() -> None:
    """
    Ignore SIGINT and SIGTERM from now on, without a race.

    The interpreter puts its Python-level handlers back to SIG_DFL while it finalizes, so a
    handler that merely does nothing would let a late signal kill an exiting process;
    SIG_IGN stays. ``signal.signal(..., SIG_IGN)`` alone may leave a signal that arrived just
    before it pending with no Python handler ("Signal 2 ignored due to race condition" on
    stderr), so the C library ignores the signals first, the pending ones then run the
    installed handler, and only then does the interpreter switch to SIG_IGN.
    """
    try:
        libc = ctypes.CDLL(None)
        libc.signal.argtypes = (ctypes.c_int, ctypes.c_void_p)
        libc.signal.restype = ctypes.c_void_p
    except (OSError, AttributeError):
        libc = None
    for stop_signal in STOP_SIGNALS:
        if libc is not None:
            libc.signal(int(stop_signal), int(signal.SIG_IGN))
    for stop_signal in STOP_SIGNALS:
        # Runs any pending handler first, then installs SIG_IGN.
        signal.signal(stop_signal, signal.SIG_IGN)


class StopSignals:
    """
    Turn the first SIGINT or SIGTERM into one stop request; ignore every later one.

    Use as a context manager around everything from ``rclpy.init`` to the last clean-up
    call. Inside, the first stop signal sets :attr:`received` and, with ``interrupt=True``,
    raises ``KeyboardInterrupt`` (only where no C++ frame calls back into Python: a plain
    Python loop or the ``SingleThreadedExecutor``). Every stop signal after the first does
    nothing, and after the block they are ignored for good (:func:`ignore_stop_signals`):
    the process is on its way out. Without a stop signal the previous handlers are
    restored on exit.

    Parameters
    ----------
    interrupt : bool
        Raise ``KeyboardInterrupt`` on the first stop signal instead of only recording it.

    Examples
    --------
    >>> with StopSignals() as stop:
    ...     stop.requested
    False

    """

    def __init__(self, interrupt: bool = False) -> None:
        self.interrupt = interrupt
        #: The number of the first stop signal received, or None.
        self.received: Optional[int] = None
        self._previous: Dict[int, _Handler] = {}

    @property
    def requested(self) -> bool:
        """Whether a stop signal has arrived."""
        return self.received is not None

    def _handle(self, signum: int, frame: Optional[FrameType]) -> None:
        # Stays installed until the end: a signal during the clean-up lands here and does
        # nothing (SIG_IGN now would race with signals already pending for the interpreter).
        if self.received is not None:
            return
        self.received = signum
        if self.interrupt:
            raise KeyboardInterrupt

    def __enter__(self) -> 'StopSignals':
        for stop_signal in STOP_SIGNALS:
            self._previous[stop_signal] = signal.signal(stop_signal, self._handle)
        return self

    def __exit__(self, *exc_info) -> None:
        if self.received is None:
            for stop_signal, handler in self._previous.items():
                signal.signal(stop_signal, handler)
        else:
            ignore_stop_signals()


def stops_on_signal(program: str) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """
    Decorate the ``main()`` of an offline tool: a stop signal ends it without a traceback.

    The first SIGINT or SIGTERM interrupts ``main`` (:class:`StopSignals` with
    ``interrupt=True``), prints ``<program>: interrupted by SIGINT`` on stderr and returns
    ``128 + signal number``; later ones are ignored.
    """
    def decorate(main: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(main)
        def guarded(*args, **kwargs) -> int:
            with StopSignals(interrupt=True) as stop:
                try:
                    return main(*args, **kwargs)
                except KeyboardInterrupt:
                    received = stop.received or signal.SIGINT
                    print(f'{program}: interrupted by {signal.Signals(received).name}',
                          file=sys.stderr)
                    return 128 + received
        return guarded
    return decorate
