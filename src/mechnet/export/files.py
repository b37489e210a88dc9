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
import zipfile
from pathlib import Path

import casadi as ca

from ..caches import BUILD_LOCK
from .contract import FORMAT_VERSION, ExportError, functions

KINDS = ("casadi", "c", "fmu")
WITH_JACOBIAN = ("ode", "alg")
SERIALISED = ("ode", "alg", "observed", "invariants", "zero", "init", "solve_alg", "jac_ode", "jac_alg",
              "forward", "alg_jac")


def export(cm, path, kind: str = "casadi", *, fmi: int = 2, overwrite: bool = False,
           _option: str | None = None) -> Path:
    """Write the compiled model to `path` (a directory; a .fmu file for kind="fmu") and return it.

    An existing path is replaced only with overwrite=True, and only when it is a previous mechnet export:
    a folder holding nothing but a model.json and the files mechnet wrote beside it (or an empty folder),
    or an FMU with mechnet's extra/org.mechnet/model.json. The working directory, its parents and any
    folder with other files in it are refused (ExportError naming the path and why), never emptied.
    The export is written into a temporary sibling and renamed into place when complete, so an
    interrupted export leaves the previous one (or nothing) at `path`. `_option` is how the caller
    names the path and the flag in messages (the CLI: "-o", "--overwrite")."""
    from ..core.arguments import flag
    if not isinstance(kind, str) or kind not in KINDS:
        raise ExportError(f"export(kind={kind!r}): kind must be one of {', '.join(map(repr, KINDS))}")
    if isinstance(fmi, bool) or not isinstance(fmi, int) or fmi not in (2, 3):
        raise ExportError(f"export(fmi={fmi!r}): FMI version must be 2 or 3")
    overwrite = flag(overwrite, "overwrite")
    names = CLI_NAMES if _option == "cli" else API_NAMES
    if not isinstance(path, (str, os.PathLike)):
        raise ExportError(f"export(path={path!r}): give a file system path (str or pathlib.Path)")
    if not os.fspath(path).strip():
        raise ExportError(f"export: {names[0]} is empty; give the folder (or .fmu file) to write")
    path = Path(path)
    if kind == "fmu":
        from .fmu import check_fmu_arguments
        check_fmu_arguments(path, fmi)
    replaceable(path, kind, overwrite, names)          # refused now, before the (long) build
    fns = functions(cm)
    if kind == "fmu":
        from .fmu import write_fmu
        return write_fmu(fns, path, fmi, overwrite, names)
    writer = write_casadi if kind == "casadi" else write_c
    return _into_place(path, kind, lambda tmp: writer(fns, tmp), overwrite, names)


#: how messages name the path and the overwrite flag: in Python, on the command line
API_NAMES = ("export(path=...)", "overwrite=True")
CLI_NAMES = ("-o", "--overwrite")
#: files mechnet writes beside model.json that model.json's "files" does not list
WRITTEN_BESIDE = ("model.json",)
_TEMPORARY = ".mechnet-tmp-"
_OLD = ".mechnet-old-"


def replaceable(path: Path, kind: str, overwrite: bool, names=API_NAMES) -> bool:
    """Whether `path` exists and may be replaced (True), does not exist (False), or an ExportError saying
    why not: it exists without overwrite, or is not a previous mechnet export (see `export`)."""
    where, flag_name = names
    if not os.path.lexists(path):
        _under_a_file(Path(path), where)
        return False
    if not overwrite:
        raise ExportError(f"export: {path} exists; pass {flag_name} to replace it (or choose another path)")
    why = _not_an_export(path, kind)
    if why:
        raise ExportError(f"export: {flag_name} replaces only a previous mechnet export, and {path} {why}; "
                          f"nothing was deleted: choose another path or remove it yourself")
    return True


def _under_a_file(path: Path, where: str) -> None:
    """ExportError when a missing `path` cannot be made because a folder it would be in is a file."""
    for parent in path.absolute().parents:
        if os.path.lexists(parent):
            if not parent.is_dir():
                raise ExportError(f"export: {where} {path} cannot be made: {parent} is a file, not a folder")
            return


def _not_an_export(path: Path, kind: str) -> str | None:
    """Why `path` is not a previous mechnet export that an export of `kind` may replace, or None."""
    if path.is_symlink():
        return "is a symbolic link"
    target, here = path.resolve(), Path.cwd().resolve()
    if target == here:
        return "is the working directory"
    if target in here.parents:
        return f"is a parent of the working directory {here}"
    try:
        if target == Path.home().resolve():
            return "is the home directory"
    except RuntimeError:                     # no home directory known
        pass
    if kind == "fmu":
        if not path.is_file():
            return "is not a file (an FMU is one .fmu file)"
        try:
            with zipfile.ZipFile(path) as archive:
                if "extra/org.mechnet/model.json" not in archive.namelist():
                    return "is an archive without mechnet's extra/org.mechnet/model.json"
        except (zipfile.BadZipFile, OSError):
            return "is not an FMU (not a zip archive)"
        return None
    if not path.is_dir():
        return "is a file, not a folder an export wrote"
    entries = list(path.iterdir())
    if not entries:
        return None
    try:
        meta = json.loads((path / "model.json").read_text(encoding="utf-8"))
    except FileNotFoundError:
        return "holds files and no model.json"
    except (OSError, ValueError):
        return "holds a model.json that is not mechnet's (not readable JSON)"
    if not isinstance(meta, dict) or meta.get("kind") not in KINDS or "format" not in meta:
        return "holds a model.json that is not mechnet's (no export kind and format)"
    ours = set(WRITTEN_BESIDE) | {name for name in _listed(meta.get("files")) if name == Path(name).name}
    others = sorted(e.name for e in entries if e.name not in ours or not e.is_file() or e.is_symlink())
    if others:
        shown = ", ".join(others[:5]) + (f" and {len(others) - 5} more" if len(others) > 5 else "")
        return f"holds files an export did not write ({shown})"
    return None


def _listed(files) -> list:
    """Every file name in model.json's "files" (strings in nested dicts and lists); a kind="c" export's
    "functions" holds C symbol names, not files, and is left out (a user's file named like a symbol
    would otherwise count as the export's and be replaced)."""
    if isinstance(files, str):
        return [files]
    if isinstance(files, dict):
        files = [v for k, v in files.items() if k != "functions"]
    if isinstance(files, list):
        return [name for item in files for name in _listed(item)]
    return []


def _into_place(path: Path, kind: str, write, overwrite: bool, names) -> Path:
    """Run write(tmp) on a new temporary sibling folder of `path`, then rename it to `path` (replacing a
    previous export there, checked again now). The temporary folder is removed on any error or
    interruption, so `path` holds either what it held before or the complete new export."""
    parent = _parent(path, names)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}{_TEMPORARY}", dir=parent))
    except OSError as exc:
        raise ExportError(f"export: cannot write in {parent} for {path} ({exc.strerror or exc})") from None
    try:
        try:
            write(tmp)
        except _SourcesOnly as exc:
            if os.path.lexists(path):        # a failed build never replaces a complete previous export
                raise ExportError(f"{exc}; {path} keeps the previous export") from None
            os.chmod(tmp, 0o777 & ~_umask())
            _swap(tmp, path, kind, overwrite, names)
            raise ExportError(str(exc).replace(str(tmp), str(path))) from None
        os.chmod(tmp, 0o777 & ~_umask())
        _swap(tmp, path, kind, overwrite, names)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return path


def _swap(new: Path, path: Path, kind: str, overwrite: bool, names) -> None:
    """Rename the finished `new` to `path`; a previous export there (checked again: it may have changed
    during the build) is moved aside first and removed after."""
    if os.path.lexists(path):
        replaceable(path, kind, overwrite, names)
    if not os.path.lexists(path):
        os.replace(new, path)
        return
    if new.is_file():
        os.replace(new, path)                # one file: atomic
        return
    old = Path(tempfile.mkdtemp(prefix=f".{path.name}{_OLD}", dir=path.parent))
    placed = False
    try:
        os.replace(path, old / path.name)
        os.replace(new, path)
        placed = True
    except BaseException:
        if os.path.lexists(old / path.name):
            kept = (f"export: {path} could not be replaced, and its previous export could not be put back: "
                    f"it is kept in {old / path.name}")
            if os.path.lexists(path):            # something made `path` again meanwhile
                raise ExportError(kept) from None
            try:
                os.replace(old / path.name, path)    # put the previous export back
            except OSError:
                raise ExportError(kept) from None
        raise
    finally:
        # the previous export is removed only once the new one is in place, or once it is back
        if placed or not os.path.lexists(old / path.name):
            shutil.rmtree(old, ignore_errors=True)


def _parent(path: Path, names) -> Path:
    """The folder `path` is written in, made when missing; ExportError when it cannot be."""
    parent = path.absolute().parent
    _under_a_file(path, names[0])
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"export: cannot make the folder {parent} for {path} "
                          f"({exc.strerror or exc})") from None
    return parent


def _umask() -> int:
    """The process's umask, read without setting it (os.umask would race with other threads)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return 0o022


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
    meta = _record(fns, "casadi", files)
    meta["sha256"] = _hashes(path, _listed(files))
    (path / "model.json").write_text(json.dumps(meta, indent=1))
    return path


def _hashes(path: Path, names) -> dict:
    """The SHA-256 of each file the export wrote (model.json's "sha256"): `load` refuses a file that does
    not match, which catches a folder mixing two exports by accident (not one made to pass)."""
    from .record import sha256
    return {name: sha256(path / name) for name in names if (path / name).is_file()}


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


def generate_c(fns: dict, path: Path, prefix: str, names: tuple = SERIALISED, extra: tuple = ()) -> list:
    """CasADi's generated C for the contract's functions `names` and its transitions, as `<prefix>.c` and
    `<prefix>.h`, each exported as `<prefix>_<name>` (two models link into one program), and the functions
    `extra` (the FMU's rest transitions) the same way; returns those
    names. With the contract's Jacobians among `names`, `ode` and `alg` also get theirs in the form
    CasADi's `external` looks for, built from the same code."""
    cg = ca.CodeGenerator(f"{prefix}.c", {"with_header": True, "prefix": f"{prefix}_"})
    exported = []
    with BUILD_LOCK:
        for f in [fns[n] for n in names] + list(fns["transition"]) + list(extra):
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
    try:
        compile_shared([path / f"{prefix}.c"], path / library)
    except ExportError as exc:
        failed = exc
    else:
        failed = None
    meta["sha256"] = _hashes(path, _listed(meta["files"]))     # the library's only when it was built
    (path / "model.json").write_text(json.dumps(meta, indent=1))
    if failed is not None:
        raise _SourcesOnly(str(failed)) from None      # the sources are kept for the user to build
    return path


class _SourcesOnly(ExportError):
    """A kind="c" export whose library could not be built: its sources are moved into place all the same."""
