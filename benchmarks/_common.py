"""What every benchmark script reports about its environment."""

from __future__ import annotations

import json
import platform
import sys
from importlib import metadata


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
