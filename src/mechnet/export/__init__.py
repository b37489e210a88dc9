"""Export a compiled model: documented functions, CasADi files, generated C, FMUs (DESIGN.md, "Export").

`cm.functions()` is the contract (`contract.py`); `cm.export(path, kind="casadi" | "c" | "fmu")` writes it;
`load(path)` reads a "casadi" export back into a model, `load_library(path)` a "c" export's functions.
"""
from .contract import FORMAT_VERSION, ExportError, functions
from .files import c_identifiers, compiler, export
from .load import ExportWarning, LoadedModel, load, load_library

__all__ = ["ExportError", "ExportWarning", "FORMAT_VERSION", "LoadedModel", "c_identifiers", "compiler", "export",
           "functions", "load", "load_library"]
