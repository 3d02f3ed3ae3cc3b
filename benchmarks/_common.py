"""What every benchmark script reports about its environment."""

from __future__ import annotations

import json
import os
import platform
import re
import sys
from importlib import metadata
from pathlib import Path


def package_versions(names, missing="not installed"):
    """Installed version of each distribution in ``names`` (``missing`` if absent)."""
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = missing
    return out


def write_json(path, results, *, packages, argv=None, **meta):
    """Write ``results`` to ``path`` with a ``meta`` entry saying how they were made.

    ``meta`` gets the keyword arguments plus the Python version, the platform,
    the versions of ``packages`` and the command-line arguments.
    """
    results = dict(results)
    results["meta"] = {
        **meta,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "versions": package_versions(packages, missing=None),
        "argv": sys.argv[1:] if argv is None else list(argv),
    }
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(results, fh, indent=1, default=float)
    print(f"wrote {path}")


#: Where this repository's checkout keeps the real recording (never copied in).
_SHARED_CAIVIAC = Path("..") / "shared" / "realdata" / "caiviac"


def caiviac_files(path=None):
    """The files the CAIVIAC ``cycles.csv`` is looked for in, in order.

    ``path`` (the file, or the folder holding it) if given; else
    ``$GREYML_CAIVIAC``, then ``../shared/realdata/caiviac`` beside this
    checkout and beside the current directory. greyml itself reads only a
    path it is given or :func:`greyml.datasets.fetch_caiviac`'s cache.
    """
    if path is not None:
        path = Path(path)
        return [path / "cycles.csv" if path.is_dir() else path]
    folders = []
    env = os.environ.get("GREYML_CAIVIAC")
    if env:
        folders.append(Path(env))
    folders.append((Path(__file__).resolve().parents[1] / _SHARED_CAIVIAC).resolve())
    here = (Path.cwd() / _SHARED_CAIVIAC).resolve()
    if here not in folders:
        folders.append(here)
    return [folder / "cycles.csv" for folder in folders]


def find_data(path=None):
    """The first of :func:`caiviac_files` that exists, or None after saying where it was looked for."""
    files = caiviac_files(path)
    found = [p for p in files if p.is_file()]
    if not found:
        print(f"CAIVIAC data not found at {', '.join(str(p) for p in files)}; skipping")
        return None
    return found[0]


def replace_generated(text, block, begin, end):
    """``text`` with the generated block from the line ``begin`` to ``end`` replaced by
    ``block`` (lines); an error when it has none."""
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if not pattern.search(text):
        raise ValueError(f"no generated block (a line {begin[:40]!r}... to {end!r}) in the page")
    return pattern.sub(lambda _: "\n".join(block), text, count=1)


def check_docs_flags(parser, args, write_docs):
    """``--write-docs`` needs ``--json`` or ``--from-json``; with ``--from-json`` the docs
    are written from that file (``write_docs(data)``) and True is returned: run nothing."""
    if args.write_docs and not (args.json or args.from_json):
        parser.error(
            "--write-docs needs --json or --from-json (the docs are written from the file)"
        )
    if args.from_json:
        if not args.write_docs:
            parser.error("--from-json goes with --write-docs")
        write_docs(json.loads(Path(args.from_json).read_text(encoding="utf-8")))
        return True
    return False


def chosen_units(parser, args, probes, quick_probes, machines, quick_machines):
    """The CAIVIAC probes and fleet machines of ``--probes`` / ``--machines`` (all, or the
    ``--quick`` subsets), each checked against what there is."""
    chosen_probes = (
        args.probes if args.probes is not None else (quick_probes if args.quick else probes)
    )
    bad = [p for p in chosen_probes if p not in probes]
    if bad:
        parser.error(f"--probes: {bad} are not CAIVIAC probes; choose from {list(probes)}")
    chosen_machines = (
        args.machines if args.machines is not None else (quick_machines if args.quick else machines)
    )
    bad = [m for m in chosen_machines if m not in machines]
    if bad:
        parser.error(f"--machines: {bad} are not fleet machines; choose from {list(machines)}")
    return chosen_probes, chosen_machines
