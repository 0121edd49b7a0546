"""Exports for renderers: LUTs as raw float32 / OpenEXR files with a JSON sidecar
(:mod:`torchirid.export.tables`), and a thin-film material as glTF
``KHR_materials_iridescence`` / OpenPBR parameters (:mod:`torchirid.export.materials`)."""

from .materials import thin_film_material, write_thin_film_material
from .tables import EXPORT_FORMATS, export_lut, read_exported_lut

__all__ = ["EXPORT_FORMATS", "export_lut", "read_exported_lut", "thin_film_material", "write_thin_film_material"]
