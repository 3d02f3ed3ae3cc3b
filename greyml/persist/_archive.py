"""Reading a model file's archive within bounds: its members, its JSON and its
arrays' headers checked and added up before anything is built."""

from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import zipfile

import numpy as np

from greyml.persist._format import (
    _ABSENT,
    _ARRAY_MEMBER,
    _ENTRY_COST,
    _JSON_COST,
    _MAX_DEPTH,
    _MAX_INT_DIGITS,
    _MAX_NPY_HEADER,
    _MODEL_MEMBER,
    _OBJECT_ENTRY_BYTES,
    _READ_CHUNK,
    FORMAT_NAME,
    FORMAT_VERSION,
    _Corrupt,
)


def _reject_constant(text):
    raise _Corrupt(f"the JSON holds the non-standard number {text}")


def _finite_float(text):
    value = float(text)
    if not math.isfinite(value):  # 1e999: too large for a float
        raise _Corrupt(f"the JSON holds the number {text[:40]}, which overflows a float")
    return value


def _bounded_int(text):
    if len(text.lstrip("-")) > _MAX_INT_DIGITS:
        raise _Corrupt(
            f"the JSON holds a whole number of {len(text.lstrip('-'))} digits; greyml writes "
            f"at most {_MAX_INT_DIGITS}"
        )
    return int(text)


def _unique_keys(pairs):
    keys = [k for k, _ in pairs]
    if len(set(keys)) != len(keys):
        raise _Corrupt("a JSON object repeats a key")
    return dict(pairs)


def _fill(stream, view, name):
    """Fill ``view`` from ``stream`` a chunk at a time; never read past its end."""
    done, size = 0, len(view)
    while done < size:
        chunk = stream.read(min(size - done, _READ_CHUNK))
        if not chunk:
            raise _Corrupt(f"{name} is shorter than its declared size (the file is truncated)")
        view[done : done + len(chunk)] = chunk
        done += len(chunk)


def _too_big(what, size, max_bytes):
    return _Corrupt(
        f"{what} {size:,} bytes, over the limit max_bytes={max_bytes:,} (if you trust the "
        "file's source, pass a larger max_bytes= to load_model)"
    )


def _read_header(archive, max_bytes, index_cost=0):
    try:
        info = archive.getinfo(_MODEL_MEMBER)
    except KeyError:
        raise _Corrupt(f"not a greyml model file (no {_MODEL_MEMBER} inside)") from None
    # greyml writes model.json and arrays/<n>.npy, each once: anything else was added
    infos = archive.infolist()
    names = [i.filename for i in infos]
    if len(set(names)) != len(names):
        raise _Corrupt("the archive holds two members of the same name; the file has been altered")
    unexpected = [n for n in names if n != _MODEL_MEMBER and not _ARRAY_MEMBER.fullmatch(n)]
    if unexpected:
        raise _Corrupt(
            f"the archive holds the unexpected member {unexpected[0]!r}; the file has been altered"
        )
    for member in infos:
        if member.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise _Corrupt(
                f"{member.filename} is compressed with zip method {member.compress_type}; "
                "greyml writes deflate only"
            )
        if member.flag_bits & 0x1:
            raise _Corrupt(f"{member.filename} is encrypted; greyml never encrypts")
    # what the archive says it holds, added up before anything is inflated
    json_cost = index_cost + _JSON_COST * info.file_size  # with zipfile's index
    declared = json_cost + sum(i.file_size for i in infos if i is not info)
    if declared > max_bytes:
        raise _too_big(
            f"its members declare (counting {_MODEL_MEMBER} {_JSON_COST} times, and the "
            "zip's index)",
            declared,
            max_bytes,
        )
    text = bytearray(info.file_size)
    with archive.open(info) as stream:
        _fill(stream, memoryview(text), _MODEL_MEMBER)
    try:
        header = json.loads(
            text.decode("utf-8"),
            parse_constant=_reject_constant,
            parse_float=_finite_float,
            parse_int=_bounded_int,
            object_pairs_hook=_unique_keys,
        )
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _Corrupt(f"{_MODEL_MEMBER} is not valid JSON ({exc})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        raise _Corrupt("not a greyml model file (wrong format name)")
    version = header.get("format_version")
    if type(version) is not int or version < 1:
        raise _Corrupt(f"invalid format version {version!r}")
    if version > FORMAT_VERSION:
        raise _Corrupt(
            f"written in model format {version} by a newer greyml "
            f"({header.get('greyml_version')}); this greyml reads format "
            f"{FORMAT_VERSION}. Upgrade greyml to load it"
        )
    if "tree" not in header:
        raise _Corrupt("the model tree is missing")
    return header, json_cost


def _nominal_size(shape, itemsize):
    """What an array counts toward ``max_bytes``: each empty axis as one entry,
    each entry as at least one byte (an array of 10**15 zero-width strings, or
    of shape (10**18, 0), costs nothing to hold but everything to go through)."""
    return math.prod(max(n, 1) for n in shape) * max(itemsize, 1)


def _object_shape(node):
    shape = node.get("shape")
    if (
        type(shape) is not list
        or len(shape) > 32
        or not all(type(n) is int and n >= 0 for n in shape)
    ):
        raise _Corrupt(f"invalid array shape {shape!r}")
    return shape


def _referenced_names(tree):
    """Every class, type, function and bit generator the tree names, by kind;
    also how often each array member is referred to (``"file"``) and what the
    object arrays count toward ``max_bytes`` (``"object_bytes"``)."""
    found = {"class": set(), "type": set(), "ufunc": set(), "bit_generator": set()}
    files: dict[str, int] = {}
    object_bytes = 0
    stack = [iter([tree])]  # iterators, not nodes: memory grows with depth only
    while stack:
        node = next(stack[-1], _ABSENT)
        if node is _ABSENT:
            stack.pop()
            continue
        if len(stack) > _MAX_DEPTH + 1:
            raise _Corrupt(f"the model tree is nested more than {_MAX_DEPTH} levels deep")
        if isinstance(node, list):
            stack.append(iter(node))
        elif isinstance(node, dict):
            kind = node.get("kind")
            if kind == "object":
                found["class"].add(str(node.get("class")))
            elif kind in ("type", "ufunc"):
                found[kind].add(str(node.get("name")))
            elif kind == "generator":
                found["bit_generator"].add(str(node.get("bit_generator")))
            # (what is malformed here is refused when the tree is built)
            if kind == "scalar" and node.get("dtype") in ("|O", "O"):
                raise _Corrupt("object scalars are not allowed")
            name = node.get("file")
            if (
                kind in ("ndarray", "scalar")
                and type(name) is str
                and _ARRAY_MEMBER.fullmatch(name)
            ):
                files[name] = files.get(name, 0) + 1
            elif kind == "object_array":
                with contextlib.suppress(_Corrupt):
                    object_bytes += _nominal_size(_object_shape(node), _OBJECT_ENTRY_BYTES)
            stack.append(iter(node.values()))
    found["file"] = files
    found["object_bytes"] = object_bytes
    return found


def _npy_header(stream, name):
    """(shape, fortran_order, dtype, header length) of an ``.npy`` member."""
    try:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            read = np.lib.format.read_array_header_1_0
        elif version == (2, 0):
            read = np.lib.format.read_array_header_2_0
        else:
            raise ValueError(f".npy format version {version} is not one greyml writes")
        shape, fortran_order, dtype = read(stream, max_header_size=_MAX_NPY_HEADER)
    except (ValueError, SyntaxError, TypeError) as exc:
        raise _Corrupt(f"the array {name} cannot be read ({exc})") from None
    if dtype.hasobject:
        raise _Corrupt(
            f"the array {name} cannot be read (it holds Python objects, which only "
            "pickle could build)"
        )
    if dtype.fields is not None or dtype.subdtype is not None or dtype.kind not in "biufcUSmM":
        raise _Corrupt(f"the array {name} has the dtype {dtype}, which greyml does not write")
    if len(shape) > 32:
        raise _Corrupt(f"the array {name} has {len(shape)} dimensions")
    return shape, fortran_order, dtype, stream.tell()


def _plan_arrays(archive, files, budget, max_bytes):
    """Read each referenced array member's header (not its data) and add up what
    the load will build: every reference a copy of its own. Returns
    ``{name: (info, header)}``."""
    plan = {}
    total = budget
    for name, count in sorted(files.items()):
        try:
            info = archive.getinfo(name)
        except KeyError:
            raise _Corrupt(f"the array {name} is missing") from None
        with archive.open(info) as stream:
            header = _npy_header(stream, name)
        shape, _, dtype, start = header
        if start + math.prod(shape) * dtype.itemsize != info.file_size:
            raise _Corrupt(
                f"the array {name} of shape {tuple(shape)} and dtype {dtype} does not fill "
                f"its member of {info.file_size} bytes"
            )
        total += count * max(info.file_size, start + _nominal_size(shape, dtype.itemsize))
        plan[name] = (info, header)
    if total > max_bytes:
        raise _too_big(
            f"loading it would build (counting {_MODEL_MEMBER} {_JSON_COST} times, the zip's "
            "index, and every reference to an array as a copy of its own)",
            total,
            max_bytes,
        )
    return plan


def _read_npy(archive, info, header):
    """An array member's data, read into an array of the planned shape."""
    shape, fortran_order, dtype, _ = header
    with archive.open(info) as stream:
        if _npy_header(stream, info.filename) != header:  # pragma: no cover - same bytes
            raise _Corrupt(f"the array {info.filename} changed while it was read")
        array = np.empty(shape[::-1] if fortran_order else shape, dtype=dtype)
        if array.nbytes:
            _fill(stream, memoryview(array.reshape(-1).view(np.uint8)), info.filename)
    return array.T if fortran_order else array


@contextlib.contextmanager
def _open_archive(path, max_bytes):
    """The zip archive at ``path``, and what zipfile's index of it takes. ``path``
    must be a regular file of at most ``max_bytes`` (a FIFO or a device such as
    /dev/zero is refused, never read), whose index fits in ``max_bytes`` too."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)  # non-blocking: opening a FIFO does not wait
    except FileNotFoundError:
        raise FileNotFoundError(f"No model file at {path}.") from None
    except IsADirectoryError:  # pragma: no cover - Windows; POSIX opens folders
        raise IsADirectoryError(f"{path} is a folder, not a model file.") from None
    with os.fdopen(fd, "rb") as handle:
        mode = os.fstat(fd)
        if stat.S_ISDIR(mode.st_mode):
            raise IsADirectoryError(f"{path} is a folder, not a model file.")
        if not stat.S_ISREG(mode.st_mode):
            raise ValueError(
                f"Cannot load {path}: it is not a regular file (a device, pipe or socket); "
                "give the path of a model file."
            )
        if mode.st_size > max_bytes:
            raise ValueError(
                f"Cannot load {path}: {_too_big('the file holds', mode.st_size, max_bytes)}."
            )
        index = _zip_index_cost(handle, mode.st_size)
        if index > max_bytes:
            too_big = _too_big("the index of its members would take", index, max_bytes)
            raise ValueError(f"Cannot load {path}: {too_big}.")
        try:
            archive = zipfile.ZipFile(handle)
        except (zipfile.BadZipFile, EOFError, ValueError):
            raise ValueError(
                f"Cannot load {path}: not a greyml model file (not a zip archive; the file "
                "may be truncated or in another format)."
            ) from None
        with archive:
            yield archive, index


def _zip_index_cost(handle, size):
    """What zipfile's index of the archive's members will take (0 if the file
    has no zip end record: zipfile then says it is not a zip). zipfile builds
    one entry (~560 bytes) for every record in the central directory, whose
    size the end record gives; a record takes at least 46 bytes."""
    tail_size = min(size, 22 + 65535 + 20 + 56)  # end record, comment, ZIP64 records
    handle.seek(size - tail_size)
    tail = handle.read(tail_size)
    handle.seek(0)
    at = tail.rfind(b"PK\x05\x06")
    if at < 0 or len(tail) - at < 22:
        return 0
    directory = int.from_bytes(tail[at + 12 : at + 16], "little")
    locator = at - 20  # a ZIP64 file gives the size in its own end record
    if locator >= 56 and tail[locator : locator + 4] == b"PK\x06\x07":
        record = tail[locator - 56 : locator]
        if record[:4] == b"PK\x06\x06":
            directory = int.from_bytes(record[40:48], "little")
    return directory // 46 * _ENTRY_COST


def _check_max_bytes(max_bytes):
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, int | np.integer):
        raise TypeError(
            f"max_bytes must be a whole number of bytes; got {type(max_bytes).__name__}."
        )
    if max_bytes < 1:
        raise ValueError(f"max_bytes must be positive; got {max_bytes}.")
    return int(max_bytes)
