"""What every benchmark script reports about its environment."""

from __future__ import annotations

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
