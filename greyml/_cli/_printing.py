"""What the ``greyml`` subcommands show: progress lines, warnings, safe text.

Everything a command writes to standard output and standard error goes
through :class:`_TerminalText` (installed by :func:`greyml.cli.main` with
:func:`terminal_safe`), which removes terminal control sequences: a column
name, test label or model file that holds them cannot clear the screen or
retitle the terminal, whichever command prints it. Only the progress line is
drawn on the stream underneath (its text passes through :func:`printable`).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import threading
import unicodedata


class Progress:
    """Numbered steps and the time elapsed on one line of standard error (tqdm).

    The line shows ``[3/14] fitting ANFISFCM on the VMC… 00:12``: the step,
    what it does and the time since the command started. It is redrawn every
    second while a step runs, and cleared at the end.

    Parameters
    ----------
    total : int
        Number of steps.
    stream : file-like, optional
        Standard error by default.
    enabled : bool, optional
        Whether to show anything; by default only when ``stream`` is a
        terminal (so logs and pipes get no progress lines).
    """

    #: Seconds between redraws while a step runs (the elapsed time moves on).
    REFRESH_S = 1.0

    def __init__(self, total, stream=None, *, enabled=None):
        # the progress line redraws itself with carriage returns: it is drawn
        # on the terminal itself, not through the stream that removes them
        self.stream = _unfiltered(sys.stderr) if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = bool(enabled)
        self.total = total
        self.done = 0
        self._bar = None
        self._stop = threading.Event()
        self._thread = None
        if self.enabled:
            from tqdm import tqdm

            # tqdm draws nothing on a terminal that reports no size (0 x 0):
            # give it 80 x 24 then
            try:
                size = os.get_terminal_size(self.stream.fileno())
            except (AttributeError, OSError, ValueError):
                size = None
            sized = size is not None and size.columns > 0 and size.lines > 0
            self._bar = tqdm(
                total=total,
                file=self.stream,
                leave=False,
                bar_format="{desc} {elapsed}",
                mininterval=0,
                dynamic_ncols=sized,
                **({} if sized else {"ncols": 80, "nrows": 24}),
            )
            self._thread = threading.Thread(target=self._tick, daemon=True)
            self._thread.start()

    def _tick(self):
        while not self._stop.wait(self.REFRESH_S):
            bar = self._bar
            if bar is not None:
                bar.refresh()

    def step(self, message):
        """Show step ``done + 1``: ``[3/14] fitting ANFISFCM on the VMC… 00:12``."""
        self.done += 1
        if self._bar is not None:
            self._bar.set_description_str(
                f"[{self.done}/{self.total}] {printable(message)}\u2026", refresh=False
            )
            self._bar.update(1)
            self._bar.refresh()

    def close(self):
        """Clear the progress line."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: ANSI escape sequences: CSI (ESC [ ... final), OSC (ESC ] ... BEL or ESC \\,
#: an unterminated one ends at the line's end), and two-character escapes.
_ANSI = re.compile(r"\x1b(?:\[[0-?]*[ -/]*[@-~]|\][^\x07\x1b\n]*(?:\x07|\x1b\\)?|[@-Z\\-_])")


def _without_control(text, *, newlines):
    """``text`` without ANSI escapes and control characters.

    Tabs, carriage returns and, unless ``newlines``, line breaks become spaces;
    with ``newlines`` a line break stays one.
    """
    text = _ANSI.sub("", str(text))
    kept = "\n" if newlines else ""
    return "".join(
        ch if ch in kept else " " if ch in "\n\r\t" else ch
        for ch in text
        if ch in "\n\r\t" or unicodedata.category(ch) not in ("Cc", "Cf")
    )


def printable(text):
    """``text`` without terminal control: ANSI escapes and control characters removed.

    What a model file or a CSV file says (``greyml_version``, ``target_name_``,
    test labels) is printed through this, so a crafted file cannot clear the
    screen or rewrite the terminal's title. Line breaks and tabs become spaces.
    """
    return _without_control(text, newlines=False)


class _TerminalText:
    """A text stream that writes what it is given without terminal control.

    Each ``write`` passes through :func:`printable`, line breaks kept: ANSI
    escapes, control characters (C0, DEL, C1) and invisible format characters
    (bidirectional overrides) are removed, tabs and carriage returns become
    spaces. Everything else (``flush``, ``isatty``, ``encoding``...) is the
    stream's underneath, :attr:`unfiltered`.
    """

    def __init__(self, stream):
        self.unfiltered = stream

    def write(self, text):
        self.unfiltered.write(_without_control(text, newlines=True))
        return len(text)

    def writelines(self, lines):
        for line in lines:
            self.write(line)

    def __getattr__(self, name):
        return getattr(self.unfiltered, name)


def _unfiltered(stream):
    """The stream underneath a :class:`_TerminalText`, else ``stream``."""
    return stream.unfiltered if isinstance(stream, _TerminalText) else stream


@contextlib.contextmanager
def terminal_safe():
    """Standard output and standard error through :class:`_TerminalText` meanwhile.

    :func:`greyml.cli.main` runs every command inside this: one printing path,
    so that no command can print a file's text raw.
    """
    saved = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = (
        None if stream is None else _TerminalText(_unfiltered(stream)) for stream in saved
    )
    try:
        yield
    finally:
        sys.stdout, sys.stderr = saved


def _progress(total, quiet):
    """Progress on standard error: off with ``quiet``, else on a terminal only."""
    return Progress(total, enabled=False if quiet else None)


def _warn(command, messages):
    for message in messages:
        print(f"greyml {command}: warning: {printable(message)}", file=sys.stderr)


def _tests_words(tests):
    tests = [printable(t) for t in tests]
    names = [f"Test {t}" if len(t) <= 4 else f"the {t} test" for t in tests]
    if len(names) == 1:
        return names[0]
    return ", ".join(names[:-1]) + " and " + names[-1]
