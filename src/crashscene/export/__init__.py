"""Export a DSL scenario (and simulated runs) to ASAM OpenSCENARIO XML 1.2 and OpenDRIVE 1.5."""
from crashscene.export.errors import ExportError

__all__ = ["ExportError"]
