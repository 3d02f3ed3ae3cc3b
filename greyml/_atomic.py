"""Writing a file whole or not at all: the one atomic writer of greyml.

Every file greyml writes (a CSV of tests, a model file, a compensator's export,
a gap report) goes through :func:`write_atomic`: the content is written to a
new temporary file in the target's folder, flushed and synced to disk, then
published under its name by a hard link (which fails if a file of that name
appeared meanwhile) or, to replace, by a rename. Whatever stops the write (an
error, Ctrl-C, SIGTERM in the ``greyml`` command) removes the temporary file and
leaves the target as it was.

Only a regular file is ever replaced: a folder, a symbolic link, a named pipe,
a device or a socket at the target is refused in one line naming it, with or
without ``overwrite`` (as root, replacing ``/dev/null`` would turn it into a
regular file).
"""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

#: What a file that is not a regular file is, by :func:`stat.S_IFMT` test.
_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISLNK, "a symbolic link"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _exists_error(path):
    """The library's refusal of an existing ``path`` without ``overwrite``."""
    return FileExistsError(f"{os.fspath(path)!r} exists; pass overwrite=True to replace it.")


def not_regular(path):
    """What stands at ``path`` if it is not a regular file ("a folder", ...), else ''.

    A symbolic link is not followed: it is itself what would be replaced.
    Nothing at ``path`` (or a path that cannot be looked at) gives ''.
    """
    try:
        mode = os.lstat(path).st_mode
    except (OSError, ValueError):
        return ""
    if stat.S_ISREG(mode):
        return ""
    return next((kind for test, kind in _KINDS if test(mode)), "not a regular file")


def refusal(path):
    """The one-line refusal to write over what is not a regular file at ``path``, or ''."""
    kind = not_regular(path)
    if not kind:
        return ""
    return (
        f"{os.fspath(path)!r} is {kind}, not a regular file; greyml replaces only a regular file."
    )


def check_target(path, overwrite, exists=None):
    """Refuse a ``path`` that :func:`write_atomic` would not write.

    Raises ``ValueError`` (:func:`refusal`) when something that is not a
    regular file is at ``path``, and ``exists`` (an exception; by default a
    :class:`FileExistsError` asking for ``overwrite=True``) when a regular file
    is there and ``overwrite`` is false. Callers check early, before the work
    that makes the content; :func:`write_atomic` checks again.
    """
    message = refusal(path)
    if message:
        raise ValueError(message)
    if not overwrite and os.path.lexists(path):
        raise exists if exists is not None else _exists_error(path)


def write_atomic(
    path, content, *, overwrite=False, exists=None, encoding="utf-8", newline=None
) -> Path:
    """Write ``content`` to ``path`` whole, or leave ``path`` as it was.

    Parameters
    ----------
    path : str or path-like
        The file to write. Its folder must exist.
    content : str, bytes or callable
        The text (written with ``encoding`` and ``newline``), the bytes, or a
        function that writes the content to the file handle it is called with:
        a text handle, or a binary one when ``encoding`` is None.
    overwrite : bool, default=False
        Replace a regular file at ``path``. Anything else there (a folder, a
        symbolic link, a named pipe, a device, a socket) is never replaced.
    exists : BaseException, optional
        What to raise when ``path`` exists and ``overwrite`` is false (checked
        before writing and again when the file is published); by default a
        :class:`FileExistsError` asking for ``overwrite=True``.
    encoding : str or None, default="utf-8"
        The encoding of text ``content``.
    newline : str, optional
        How text ``content`` writes its line ends (as :func:`open` takes it).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If something that is not a regular file is at ``path``.
    """
    path = Path(path)
    check_target(path, overwrite, exists)
    temp = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.part"
    fd = None
    try:
        fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        binary = isinstance(content, bytes) or (callable(content) and encoding is None)
        opened = (
            os.fdopen(fd, "wb")
            if binary
            else os.fdopen(fd, "w", encoding=encoding, newline=newline)
        )
        with opened as handle:
            if callable(content):
                content(handle)
            else:
                handle.write(content)
            handle.flush()
            os.fsync(handle.fileno())
        _publish(temp, path, overwrite, exists)
        if os.path.lexists(temp):  # the name left after a hard link
            os.unlink(temp)
    except BaseException:
        if fd is not None:  # else os.open met a file of that name, not ours to remove
            _remove(temp)
        raise
    return path


def _publish(temp, path, overwrite, exists):
    """Give the written ``temp`` the name ``path``: a rename that replaces a regular
    file when ``overwrite``, else a hard link that fails on any file made meanwhile."""
    if overwrite:
        message = refusal(path)  # again: something may have been put there meanwhile
        if message:
            raise ValueError(message)
        os.replace(temp, path)
        return
    try:
        os.link(temp, path)
    except FileExistsError:
        raise exists if exists is not None else _exists_error(path) from None
    except OSError:  # no hard links on this file system: check, then rename
        if os.path.lexists(path):
            raise exists if exists is not None else _exists_error(path) from None
        os.replace(temp, path)


def _remove(path):
    """Remove the file ``path`` if it exists."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
