"""The compile pipeline: flatten, simplify, analyze, emit."""
from .compiled import CompiledModel
from .pipeline import CompileOptions, compile_model

__all__ = ["CompileOptions", "CompiledModel", "compile_model"]
