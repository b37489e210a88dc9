"""`mechnet.export.load(path)`: an exported model back, without the scene code that built it."""
from __future__ import annotations

import os
import sys
import json
import struct
import warnings
from pathlib import Path

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK
from ..compile.artifacts import Selection, SemiExplicitDAE
from ..compile.compiled import CompiledModel
from .contract import ExportError
from .files import SERIALISED
from .record import check_fit, check_hashes, check_record, read_format


class ExportWarning(UserWarning):
    """A loaded model that may not serve every run its scene served (a re-selection it cannot make)."""


def read_record(path) -> dict:
    """model.json of an export, checked: present, readable, a mapping, and of a format this mechnet reads."""
    if not isinstance(path, (str, os.PathLike)):
        raise ExportError(f"load(path={path!r:.80}): give the folder cm.export() wrote (a str or pathlib.Path)")
    path = Path(path)
    record_file = path / "model.json"
    if not record_file.is_file():
        raise ExportError(f"load: {path} holds no model.json; give the directory cm.export() wrote")
    try:
        record = json.loads(record_file.read_text())
    except (OSError, ValueError) as exc:
        raise ExportError(f"load: {record_file} cannot be read: {exc}") from None
    read_format(record, record_file)
    return record


# --- inspecting a serialised function before CasADi reads it -------------------------------------------
# `Function.save` writes CasADi's serialisation: every byte as two letters ('a' + low nibble, then 'a' + high
# nibble), a header (a check number, the protocol version, a debug flag), then the function. Every function
# in it, nested ones included, is a shared definition: the flag 'd', a null flag (0 for a function), and the
# name of its base class as a length-prefixed string, then its fields: ProtoFunction's (version 2: the name,
# five flags), FunctionInternal's (version 9: differentiability, sparsities, names, then the JIT fields:
# jit, jit_cleanup, jit_serialize, jit_temp_suffix, jit_base_name, jit_options, compiler_plugin).
# Reading a file CasADi compiles a function whose `jit` is set, with the compiler command of its
# `jit_options` (a shell command), and opens the shared library of an `External`; a jit_serialize of
# "embed" or "link" writes and opens a library. So before `Function.load`, every place the file could
# hold a function definition (every byte string CasADi would read as one, wherever it sits) is looked at:
# its class must be one mechnet writes, and its JIT fields the defaults (no jit, "source", no options,
# the "shell" plugin name mechnet never uses).
_CHECK, _PROTOCOL = 123456789012345, 3
_WRITTEN = ("SXFunction", "MXFunction", "Switch")          # the classes mechnet's exports hold
_CASADI_CLASSES = ("MXFunction", "SXFunction", "Interpolant", "Switch", "Map", "MapSum", "Nlpsol", "Rootfinder",
                   "Integrator", "External", "Conic", "FmuFunction", "BlazingSplineFunction", "Onnx")
_PROTO_VERSION, _FUNCTION_VERSIONS = 2, (9,)


def _decoded(data: bytes) -> bytes:
    """The bytes CasADi's DeserializingStream reads from `data` (two characters a byte, as it reads them)."""
    raw = np.frombuffer(data[:len(data) // 2 * 2], dtype=np.uint8).astype(np.int64)
    return (((raw[0::2] - 97) + ((raw[1::2] - 97) << 4)) & 0xFF).astype(np.uint8).tobytes()


class _Reader:
    def __init__(self, data: bytes, at: int):
        self.data, self.at = data, at

    def take(self, n: int) -> bytes:
        if n < 0 or self.at + n > len(self.data):
            raise ValueError("the file ends inside a function's fields")
        out = self.data[self.at:self.at + n]
        self.at += n
        return out

    def int32(self) -> int:
        return struct.unpack("<i", self.take(4))[0]

    def int64(self) -> int:
        return struct.unpack("<q", self.take(8))[0]

    def flag(self) -> bool:
        return self.take(1) != b"\x00"

    def string(self) -> str:
        return self.take(self.int32()).decode("latin-1")

    def count(self) -> int:
        n = self.int64()
        if n < 0 or n > len(self.data):
            raise ValueError(f"a list of {n} entries")
        return n

    def sparsity(self):
        kind = self.take(1)
        if kind == b"d":
            self.take(8 * self.count())
        elif kind == b"r":
            self.int64()
        else:
            raise ValueError(f"a sparsity flagged {kind!r}")


def _function_fields(data: bytes, at: int, cls: str) -> str | None:
    """Why the function whose fields start at `at` could run code when read (None: it cannot)."""
    r = _Reader(data, at)
    if r.int32() != _PROTO_VERSION:
        return f"{cls} is in a serialisation version this mechnet cannot check"
    name = r.string()
    r.take(5)
    if r.int32() not in _FUNCTION_VERSIONS:
        return f"{cls} {name!r} is in a serialisation version this mechnet cannot check"
    for _ in range(2):
        r.take(r.count())
    for _ in range(2):
        for _ in range(r.count()):
            r.sparsity()
    for _ in range(2):
        for _ in range(r.count()):
            r.string()
    jit, _cleanup, serialize = r.flag(), r.flag(), r.string()
    if jit:
        return f"function {name!r} is to be JIT-compiled (option 'jit')"
    if serialize != "source":
        return f"function {name!r} carries a compiled library (jit_serialize={serialize!r})"
    r.flag()
    r.string()
    if r.int64() != 0:
        return f"function {name!r} carries 'jit_options' (a compiler command)"
    plugin = r.string()
    if plugin not in ("shell", ""):
        return f"function {name!r} names the compiler plugin {plugin!r} (option 'compiler')"
    return None


def inspect_function_file(file) -> None:
    """Refuse (ExportError naming the file) a serialised CasADi function that could run code when read:
    one with a function of a class mechnet does not write (an `External` opens a shared library), or with
    JIT options (`jit`, `compiler`, `jit_options`, an embedded or linked library). Nothing is deserialised."""
    file = Path(file)
    try:
        data = _decoded(file.read_bytes())
    except OSError as exc:
        raise ExportError(f"load: {file} cannot be read: {exc}") from None
    head = _Reader(data, 0)
    try:
        check, protocol, debug = head.int64(), head.int64(), head.flag()
    except ValueError:
        check = protocol = debug = None
    if check != _CHECK or protocol != _PROTOCOL or debug:
        raise ExportError(f"load: {file} is not a CasADi function serialised as mechnet writes one "
                          f"(refused unread)")
    for cls in _CASADI_CLASSES:
        key = b"d\x00" + struct.pack("<i", len(cls)) + cls.encode()
        at = data.find(key)
        while at >= 0:
            if cls not in _WRITTEN:
                raise ExportError(f"load: {file} holds a CasADi {cls} function, which mechnet never exports "
                                  f"and which could run code when read (refused unread)")
            try:
                reason = _function_fields(data, at + len(key), cls)
            except (ValueError, struct.error, UnicodeDecodeError) as exc:
                reason = f"a {cls} whose fields cannot be checked ({exc})"
            if reason is not None:
                raise ExportError(f"load: {file}: {reason}; it could run code when read (refused unread)")
            at = data.find(key, at + 1)


def _member(path: Path, value, key: str) -> Path:
    """The file `value` of model.json's `key`, confined to the export folder `path`."""
    if not isinstance(value, str) or not value:
        raise ExportError(f"load: model.json {key} must be a file name in {path}, not {value!r}")
    candidate = Path(value)
    if candidate.is_absolute() or ".." in candidate.parts:
        raise ExportError(f"load: model.json {key} = {value!r} leaves the export folder {path}; "
                          f"give a file name inside it")
    file = path / candidate
    try:
        inside = file.resolve(strict=True).is_relative_to(path.resolve(strict=True))
    except (OSError, RuntimeError):
        raise ExportError(f"load: model.json {key} = {value!r}: {file} is missing") from None
    if not inside:
        raise ExportError(f"load: model.json {key} = {value!r} leads out of the export folder {path} "
                          f"(a link); refused")
    if not file.is_file():
        raise ExportError(f"load: model.json {key} = {value!r}: {file} is not a file")
    return file


def _function(file: Path) -> ca.Function:
    """The CasADi function of an export's file, inspected before CasADi reads it."""
    inspect_function_file(file)
    try:
        return ca.Function.load(str(file))
    except RuntimeError as exc:
        raise ExportError(f"load: {file} is not a CasADi function CasADi can read: "
                          f"{str(exc).strip().splitlines()[-1][:300]}") from None


def _members(path: Path, files) -> dict:
    """model.json's "files" of a kind="casadi" export: {key as messages name it: (name, file)}, each file
    confined to the folder; every function the contract names must be there, and nothing else."""
    if not isinstance(files, dict):
        raise ExportError(f"load: model.json 'files' must map each function to its file in {path}, "
                          f"not {files!r:.80}")
    for key in ("transition", "rest"):
        if not isinstance(files.get(key, []), list):
            raise ExportError(f"load: model.json files[{key!r}] must be a list of file names, "
                              f"not {files.get(key)!r:.80}")
    transitions = files.get("transition", [])
    rests = files.get("rest", [None] * len(transitions))
    if len(rests) != len(transitions):
        raise ExportError(f"load: model.json files['rest'] holds {len(rests)} entries for "
                          f"{len(transitions)} transitions (files['transition'])")
    missing = [name for name in SERIALISED if name not in files]
    if missing:
        raise ExportError(f"load: model.json 'files' lacks {', '.join(map(repr, missing))}")
    unknown = [name for name in files if name not in (*SERIALISED, "transition", "rest")]
    if unknown:
        raise ExportError(f"load: model.json files[{unknown[0]!r}] is no function of the contract an export "
                          f"writes ({', '.join(SERIALISED)}, transition, rest)")
    keyed = {f"files[{name!r}]": files[name] for name in SERIALISED}
    keyed.update({f"files['transition'][{k}]": f for k, f in enumerate(transitions)})
    keyed.update({f"files['rest'][{k}]": f for k, f in enumerate(rests) if f is not None})
    return {key: (value, _member(path, value, key)) for key, value in keyed.items()}


def load(path) -> "LoadedModel":
    """The model of a kind="casadi" export: it simulates, linearises and exports again like the
    compiled model it came from (the same functions, evaluated bitwise alike), with the choice of
    states the export holds (`model.json` "selection").

    Nothing in the folder runs: each function file is inspected before CasADi reads it and refused
    (ExportError naming the file) when it holds a class mechnet never writes (an `External` library) or
    JIT settings; model.json's files must lie in the folder and its entries are checked, with errors
    naming the key (`record.py`: types, sizes against the functions', parameter values within their
    checks), and each file must match the SHA-256 model.json recorded for it at export. The checks catch
    an edited or mixed-up folder, not a crafted one holding another model's consistent functions and
    record (docs/export.md, "What is trusted")."""
    record = read_record(path)
    path = Path(path)
    if "kind" not in record:
        raise ExportError(f"load: {path / 'model.json'} 'kind' is missing (the export kind, 'casadi')")
    if record["kind"] != "casadi":
        hint = (" (a kind='c' export: mechnet.export.load_library gives its functions)"
                if record.get("kind") == "c" else "")
        raise ExportError(f"load: {path} is a kind={record.get('kind')!r} export; load reads kind='casadi'{hint}")
    check_record(record, path / "model.json")
    members = _members(path, record.get("files"))
    check_hashes(record, {name: file for name, file in members.values()}, path / "model.json")
    with BUILD_LOCK:
        loaded = {key: _function(file) for key, (_, file) in members.items()}
    fns = {name: loaded[f"files[{name!r}]"] for name in SERIALISED}
    n = len(record["files"].get("transition", []))
    fns["transition"] = tuple(loaded[f"files['transition'][{k}]"] for k in range(n))
    fns["rest"] = tuple(loaded.get(f"files['rest'][{k}]") for k in range(n))
    check_fit(record, fns, path / "model.json")
    selection = record["selection"]
    if not selection["holds"]:
        warnings.warn(f"model {record['name']!r} loaded from {path} keeps the states {', '.join(selection['states'])} "
                      f"throughout, but its scene may need another choice during a run ({selection['reason']}); "
                      f"a run that needs one fails where that choice becomes singular", ExportWarning, stacklevel=2)
    return LoadedModel(record, _dae(record, fns), fns)


def load_library(path) -> dict:
    """The functions of a kind="c" export, from its shared library (CasADi `external`), by contract
    name: "ode", "alg", ..., "transition_0", ...

    The library is native code: loading it runs it (its initialisers run as it is opened), so load only
    libraries you trust. The library must be a file inside the folder (no absolute path, `..` or link leading
    out) and, when model.json records its SHA-256, match it (a library rebuilt from the sources does not:
    delete its entry in model.json's "sha256" to load one you built yourself)."""
    record = read_record(path)
    path = Path(path)
    if record.get("kind") != "c":
        raise ExportError(f"load_library: {path} is a kind={record.get('kind')!r} export, not kind='c'")
    files = record.get("files")
    if not isinstance(files, dict) or not isinstance(files.get("functions"), dict) or not all(
            isinstance(k, str) and isinstance(v, str) and v.isidentifier() for k, v in files["functions"].items()):
        raise ExportError(f"load_library: model.json 'files' must hold \"library\" and \"functions\" (contract "
                          f"names to C symbols), not {files!r:.200}")
    if isinstance(files.get("library"), str) and not (path / files["library"]).exists() \
            and Path(files["library"]).name == files["library"]:
        raise ExportError(f"load_library: {path / files['library']} is missing; build {files.get('source')} "
                          f"into it")
    library = _member(path, files.get("library"), "files['library']")
    # the table checked whatever it holds; the library only where it has an entry (one rebuilt from the
    # sources loads once its entry is deleted)
    hashes = record.get("sha256")
    check_hashes(record, {files["library"]: library} if isinstance(hashes, dict) and files["library"] in hashes
                 else {}, path / "model.json")
    with BUILD_LOCK:
        return {name: ca.external(symbol, str(library)) for name, symbol in files["functions"].items()}


def _dae(record: dict, fns: dict) -> SemiExplicitDAE:
    """The compiled model's record rebuilt around the loaded functions, with fresh symbols."""
    def symbols(key):
        items = record[key]
        return ca.vertcat(*[ca.SX.sym(v["name"]) for v in items]) if items else ca.SX(0, 1)

    with BUILD_LOCK:
        t, x, z, u, p, d = ca.SX.sym("t"), *(symbols(k) for k in "xzupd")
    names = {k: tuple(v["name"] for v in record[k]) for k in "xzupd"}
    checks = {v["name"]: (_declaration(v), v.get("owner", v["name"])) for v in record["p"]}
    info = {"alg_labels": tuple(record["alg_labels"]), "linear_tears": tuple(record.get("linear_tears", ())),
            "folded_parameters": tuple(record["folded_parameters"]),
            "parameter_requirements": tuple(record.get("parameter_requirements", ())),
            "nominal": {v["name"]: v["nominal"] for v in record["observed"]}, "parameter_checks": checks,
            "solved": 0, "torn": len(record["z"]), "observed_only": 0,
            "quaternions": tuple(tuple(index) for index in record.get("quaternions", ())),
            "zero_at_start": tuple(bool(e.get("at_start", False)) for e in record["zero"]),
            "rest_transition": tuple(fns.get("rest", ()))}
    return SemiExplicitDAE(
        name=record["name"], t=t, x=x, z=z, u=u, p=p, d=d,
        x_names=names["x"], z_names=names["z"], u_names=names["u"], p_names=names["p"], d_names=names["d"],
        ode=fns["ode"], alg=fns["alg"], observed=fns["observed"],
        observed_names=tuple(v["name"] for v in record["observed"]),
        zero=fns["zero"], transition=fns["transition"], invariants=fns["invariants"],
        invariant_names=tuple(record["invariants"]),
        selections=(Selection(names["x"], names["z"], fns["ode"], fns["alg"], fns["observed"]),),
        x_nominal=tuple(v["nominal"] for v in record["x"]), z_nominal=tuple(v["nominal"] for v in record["z"]),
        units={v["name"]: v["unit"] for v in record["observed"]},
        starts={s["name"]: s["value"] for s in record["declared_starts"]},
        guesses=dict(record["guesses"]),
        u_default=tuple(v["default"] for v in record["u"]), p_value=tuple(v["value"] for v in record["p"]),
        d_value=tuple(v["start"] for v in record["d"]),
        time_events=tuple((tt, cause) for tt, cause in record["time_events"]),
        zero_labels=tuple(e["label"] for e in record["zero"]),
        zero_directions=tuple(e["direction"] for e in record["zero"]), info=info)


def check_named(where: str):
    """The parameter check an export names (a name in core/declarations.py, or "module:name" elsewhere in
    mechnet), or None. Nothing is imported on the file's word, and only a function marked as a
    parameter check is returned (`declarations.parameter_check`)."""
    from ..core import declarations
    module, _, name = where.rpartition(":")
    if module and not module.startswith("mechnet."):
        return None
    check = getattr(sys.modules.get(module) if module else declarations, name, None) if name else None
    return check if callable(check) and getattr(check, "is_parameter_check", False) else None


def _declaration(entry: dict):
    """A parameter's check as the scene declared it (by the name of one of core/declarations.py's checks,
    or "module:name" of one elsewhere in mechnet: `contract._check`), so a new value is refused as it was
    before export; None when the check was the user's own function (a new value must then be finite), or
    names anything that is not a parameter check of a module mechnet has loaded."""
    from ..core import declarations
    check = check_named(entry.get("check") or "")
    if check is None:
        return None
    decl = declarations.Param(entry["value"], unit=entry["unit"], doc=entry.get("doc", ""), check=check)
    decl.name = entry["name"].rsplit(".", 1)[-1]
    return decl


class LoadedModel(CompiledModel):
    """A compiled model read from a kind="casadi" export: everything that runs on the compiled model
    works (simulate, linearize, trim, functions, export); the compile stages are not there."""

    def __init__(self, record: dict, dae: SemiExplicitDAE, fns: dict):
        super().__init__(record["name"], {"dae": dae}, {}, None)
        self.record = record
        dae.info["_export_functions"] = {**fns, "metadata": {k: v for k, v in record.items()
                                                             if k not in ("kind", "files", "c_names", "sha256")}}

    def summary(self) -> str:
        r = self.record
        kind = "explicit ODE" if not r["z"] else "index-1 DAE"
        return "\n".join([
            f"model {r['name']!r}: {kind}, loaded from an export (format {r['format']})",
            f"  states ({len(r['x'])}): {', '.join(v['name'] for v in r['x'])}",
            f"  algebraics ({len(r['z'])}): {', '.join(v['name'] for v in r['z']) or '-'}",
            f"  inputs ({len(r['u'])}): {', '.join(v['name'] for v in r['u']) or '-'}",
            f"  tunable parameters ({len(r['p'])}): {', '.join(v['name'] for v in r['p']) or '-'}",
            f"  modes ({len(r['d'])}): {', '.join(v['name'] for v in r['d']) or '-'}",
            f"  selection: {r['selection']['reason']}",
            f"  cost: {self.dae.ode.n_instructions()} instructions in ode, {self.dae.alg.n_instructions()} in alg",
        ])
