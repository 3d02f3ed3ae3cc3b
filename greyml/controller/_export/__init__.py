"""A Compensator as code for a controller: C, IEC 61131-3 Structured Text or JSON (private).

One intermediate program (:class:`~greyml.controller._export._program.Program`,
built by ``describe`` from a compensator's checked update plan) and a writer
per language: C99 (``_c``), Structured Text for TwinCAT 3 / CODESYS (``_st``)
and JSON. :meth:`greyml.Compensator.export` is the front door (and ``greyml export`` on
the command line); :func:`export_compensator` writes a file and
:func:`export_text` gives the text.
"""

from greyml.controller._export._write import LANGUAGES, export_compensator, export_text

__all__ = ["LANGUAGES", "export_compensator", "export_text"]
