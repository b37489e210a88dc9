"""`cm.export(path, kind=...)`: the contract written as files (`kind="casadi"`, `"c"`, `"fmu"`).

Every kind writes `model.json` (the contract's metadata, the file of each
function, the C identifiers of the names) beside the functions; `load(path)`
reads a "casadi" export back into a model that simulates without the scene code.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from ..caches import BUILD_LOCK
from .contract import FORMAT_VERSION, ExportError, functions

KINDS = ("casadi", "c", "fmu")
WITH_JACOBIAN = ("ode", "alg")
SERIALISED = ("ode", "alg", "observed", "invariants", "zero", "init", "solve_alg", "jac_ode", "jac_alg",
              "forward", "alg_jac")


def export(cm, path, kind: str = "casadi", *, fmi: int = 2, overwrite: bool = False) -> Path:
    """Write the compiled model to `path` (a directory; a .fmu file for kind="fmu") and return it.
    An existing path is replaced only with overwrite=True."""
    from ..core.arguments import flag
    if kind not in KINDS:
        raise ExportError(f"export(kind={kind!r}): kind must be one of {', '.join(map(repr, KINDS))}")
    overwrite = flag(overwrite, "overwrite")
    if not isinstance(path, (str, os.PathLike)):
        raise ExportError(f"export(path={path!r}): give a file system path (str or pathlib.Path)")
    path = Path(path)
    if path.exists():
        if not overwrite:
            raise ExportError(f"export: {path} exists; pass overwrite=True to replace it (or choose another path)")
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    fns = functions(cm)
    if kind == "fmu":
        from .fmu import write_fmu
        return write_fmu(fns, path, fmi)
    path.mkdir(parents=True)
    if kind == "casadi":
        return write_casadi(fns, path)
    return write_c(fns, path)


def c_identifiers(names) -> dict:
    """Each name's C identifier: characters other than letters, digits and _ become _, a leading
    digit gets a _ in front, and a clash with an earlier name gets _2, _3, ... (in name order, so the
    same names always give the same identifiers)."""
    out, taken = {}, set()
    for name in names:
        base = re.sub(r"\W", "_", name, flags=re.ASCII)
        base = "_" + base if not base or base[0].isdigit() else base
        ident, k = base, 2
        while ident in taken:
            ident, k = f"{base}_{k}", k + 1
        taken.add(ident)
        out[name] = ident
    return out


def _record(fns: dict, kind: str, files: dict) -> dict:
    meta = dict(fns["metadata"])
    meta["kind"] = kind
    meta["files"] = files
    meta["c_names"] = c_identifiers([meta["name"], *[v["name"] for v in meta["observed"]]])
    return meta


def write_casadi(fns: dict, path: Path) -> Path:
    files = {}
    with BUILD_LOCK:
        for name in SERIALISED:
            fns[name].save(str(path / f"{name}.casadi"))
            files[name] = f"{name}.casadi"
        for k, f in enumerate(fns["transition"]):
            f.save(str(path / f"transition_{k}.casadi"))
        files["transition"] = [f"transition_{k}.casadi" for k in range(len(fns["transition"]))]
        files["rest"] = []
        for k, f in enumerate(fns.get("rest", ())):
            if f is not None:
                f.save(str(path / f"rest_{k}.casadi"))
            files["rest"].append(None if f is None else f"rest_{k}.casadi")
    (path / "model.json").write_text(json.dumps(_record(fns, "casadi", files), indent=1))
    return path


def compiler() -> str | None:
    """The system C compiler ($CC, else cc, gcc or clang on PATH), or None."""
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate.split()[0]):
            return candidate
    return None


def compile_shared(sources: list, output: Path, include: list = (), defines: dict | None = None) -> None:
    """Build a shared library from C sources with the system compiler; ExportError naming the compiler
    and its first lines of complaint when that fails, or when there is none."""
    cc = compiler()
    if cc is None:
        raise ExportError(f"no C compiler found ($CC, cc, gcc or clang): the C sources are in {output.parent}; "
                          f"build them with one, or export kind='casadi', which needs none")
    # -O1: as fast as -O2 on generated straight-line code (chain of 20: ode 5.3 vs 5.4 µs, its Jacobian
    # 35.6 vs 35.0 µs) and three times quicker to build (Jacobian 6.9 vs 20 s)
    cmd = [*cc.split(), "-shared", "-fPIC", "-O1", *[f"-I{d}" for d in include],
           *[f"-D{k}={v}" for k, v in (defines or {}).items()], *map(str, sources),
           "-o", str(output), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise ExportError(f"{cc} could not build {output.name}: {done.stderr.strip()[:600]}")


def generate_c(fns: dict, path: Path, prefix: str, names: tuple = SERIALISED) -> list:
    """CasADi's generated C for the contract's functions `names` and its transitions, as `<prefix>.c` and
    `<prefix>.h`, each exported as `<prefix>_<name>` (two models link into one program); returns those
    names. With the contract's Jacobians among `names`, `ode` and `alg` also get theirs in the form
    CasADi's `external` looks for, built from the same code."""
    cg = ca.CodeGenerator(f"{prefix}.c", {"with_header": True, "prefix": f"{prefix}_"})
    exported = []
    with BUILD_LOCK:
        for f in [fns[n] for n in names] + list(fns["transition"]):
            args = f.mx_in()
            wrapped = ca.Function(f"{prefix}_{f.name()}", args, f.call(args), f.name_in(), f.name_out())
            cg.add(wrapped)
            exported.append(wrapped.name())
            if f.name() in WITH_JACOBIAN and f"jac_{f.name()}" in names:
                cg.add(_named_jacobian(wrapped, fns[f.name()], fns[f"jac_{f.name()}"]))
        with tempfile.TemporaryDirectory() as tmp:
            cg.generate(tmp + os.sep)
            for name in (f"{prefix}.c", f"{prefix}.h"):
                shutil.copy(Path(tmp) / name, path / name)
    return exported


def _named_jacobian(wrapped: ca.Function, f: ca.Function, jac: ca.Function) -> ca.Function:
    """f's Jacobian (by every input) as CasADi's `external` looks for it, jac_<name>: the blocks by x, z, u
    and p are the contract's Jacobian `jac` (one copy of its code in the library), those by t and d are
    differentiated here (one and nd columns)."""
    template = wrapped.jacobian()
    args = template.mx_in()
    inputs = args[:f.n_in()]
    by_contract = dict(zip("xzup", jac.call(inputs)))
    value = f.call(inputs)[0]
    blocks = [by_contract[name] if name in by_contract else ca.jacobian(value, inputs[k])
              for k, name in enumerate(f.name_in())]
    return ca.Function(f"jac_{wrapped.name()}", args, blocks, template.name_in(), template.name_out())


def write_c(fns: dict, path: Path) -> Path:
    meta = _record(fns, "c", {})
    prefix = meta["c_names"][meta["name"]]
    names = generate_c(fns, path, prefix)
    library = f"lib{prefix}.so"
    meta["files"] = {"source": f"{prefix}.c", "header": f"{prefix}.h", "library": library,
                     "functions": {n[len(prefix) + 1:]: n for n in names}}
    (path / "model.json").write_text(json.dumps(meta, indent=1))
    compile_shared([path / f"{prefix}.c"], path / library)
    return path
