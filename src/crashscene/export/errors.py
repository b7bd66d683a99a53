"""The export stage's exception: what was wrong, where (file, field path) and what is allowed."""
from __future__ import annotations


class ExportError(ValueError):
    """An input the exporter cannot turn into OpenSCENARIO/OpenDRIVE (corrupt, unsupported, missing)."""
