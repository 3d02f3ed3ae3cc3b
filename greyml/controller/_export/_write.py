"""Writing a Compensator's export: C, IEC 61131-3 Structured Text or JSON, to a file.

All three come from one :class:`greyml.controller._export._program.Program`; the file is
written beside its final name and renamed, so a failure leaves none, and an
existing file is replaced only when asked.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from greyml._atomic import write_atomic
from greyml.controller._export._c import write_c
from greyml.controller._export._program import describe
from greyml.controller._export._st import write_st

__all__ = ["LANGUAGES", "export_compensator", "export_text"]


def _write_json(program):
    return json.dumps(program.to_dict(), indent=2, allow_nan=False, ensure_ascii=True) + "\n"


#: The languages of :meth:`Compensator.export`, with the writer of each.
LANGUAGES = {"c": write_c, "st": write_st, "json": _write_json}


def export_text(comp, language, *, name="greyml_compensator", description=None):
    """The export of ``comp`` in ``language`` as text (see :func:`export_compensator`)."""
    if language not in LANGUAGES:
        raise ValueError(
            f"Compensator.export: the language {language!r} is not one of "
            f"{', '.join(map(repr, LANGUAGES))}."
        )
    return LANGUAGES[language](describe(comp, name=name, description=description))


def export_compensator(
    comp, language, path, *, name="greyml_compensator", description=None, overwrite=False
):
    """Write the export of ``comp`` to ``path`` (see :meth:`Compensator.export`)."""
    text = export_text(comp, language, name=name, description=description)
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"Compensator.export: {os.fspath(path)!r} is a folder; give a file name.")
    return write_atomic(path, text, overwrite=overwrite, encoding="ascii", newline="\n")
