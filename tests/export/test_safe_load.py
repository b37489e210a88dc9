"""export.load refuses, before CasADi reads them, function files that would run code when read (a JIT
compiler command, an External library), and model.json entries that leave the folder or are tampered."""
import json
import os
import shutil
import subprocess

import casadi as ca
import pytest

from mechnet.export import ExportError, compiler, load
from models import cartesian_pendulum

needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler on this machine")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    return cartesian_pendulum().compile().export(tmp_path_factory.mktemp("exp") / "pendulum")


@pytest.fixture
def folder(exported, tmp_path):
    return shutil.copytree(exported, tmp_path / "copy")


def _like(folder, name):
    """A Function of ode's signature, evaluated like x -> xdot = 0."""
    ode = ca.Function.load(str(folder / "ode.casadi"))
    args = ode.sx_in()
    return ca.Function(name, args, [ca.SX.zeros(ode.sparsity_out(0))], ode.name_in(), ode.name_out())


def test_an_export_loads(folder):
    """(The pendulum's export keeps one selection, and says so when loaded: an expected ExportWarning.)"""
    from mechnet.export import ExportWarning
    with pytest.warns(ExportWarning, match="keeps the states"):
        assert load(folder).record["name"]


@needs_cc
def test_a_jit_compiler_command_is_refused_unrun(folder, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "MARKER"
    ode = ca.Function.load(str(folder / "ode.casadi"))
    args = ode.sx_in()
    crafted = ca.Function("ode", args, ode.call(args), ode.name_in(), ode.name_out(),
                          {"jit": True, "compiler": "shell", "jit_options": {"compiler": f"touch {marker}; gcc"}})
    marker.unlink()                            # made while building the payload: it does run code
    crafted.save(str(folder / "ode.casadi"))
    _rehash(folder)
    with pytest.raises(ExportError, match=r"ode\.casadi.*jit"):
        load(folder)
    assert not marker.exists()


@needs_cc
def test_an_external_library_is_refused_unopened(folder, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "MARKER_EXT"
    inner = _like(folder, "evil")
    cg = ca.CodeGenerator("evil.c")
    cg.add(inner)
    cg.generate(str(tmp_path) + os.sep)
    with open(tmp_path / "evil.c", "a") as src:
        src.write(f'\n#include <stdio.h>\n__attribute__((constructor)) static void mark(void) '
                  f'{{ FILE* f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    library = folder / "libevil.so"
    subprocess.run(["gcc", "-shared", "-fPIC", str(tmp_path / "evil.c"), "-o", str(library), "-lm"], check=True)
    ext = ca.external("evil", str(library))
    marker.unlink()
    args = ext.mx_in()
    ca.Function("observed", args, ext.call(args)).save(str(folder / "invariants.casadi"))
    _rehash(folder)
    with pytest.raises(ExportError, match=r"invariants\.casadi.*External"):
        load(folder)
    assert not marker.exists()


@pytest.mark.parametrize("options, words", [({"jit": True, "compiler": "shell"}, "jit"),
                                            ({"jit_options": {"compiler": "touch X; gcc"}}, "jit_options")])
def test_jit_options_are_refused_even_without_a_compiler(folder, options, words):
    ode = ca.Function.load(str(folder / "ode.casadi"))
    args = ode.sx_in()
    try:
        ca.Function("ode", args, ode.call(args), ode.name_in(), ode.name_out(), options).save(
            str(folder / "ode.casadi"))
    except RuntimeError:
        pytest.skip("CasADi will not build this function here")
    _rehash(folder)
    with pytest.raises(ExportError, match=rf"ode\.casadi.*{words}"):
        load(folder)


def _rehash(folder):
    """model.json's SHA-256 of every file as the folder holds it now: a crafted folder passes that check,
    which only catches accidental mixing; the function checks must still refuse it."""
    from mechnet.export.record import sha256
    _tamper(folder, lambda r: r["sha256"].update({name: sha256(folder / name) for name in r["sha256"]}))


def _tamper(folder, change):
    record = json.loads((folder / "model.json").read_text())
    change(record)
    (folder / "model.json").write_text(json.dumps(record))


@pytest.mark.parametrize("value", ["../ode.casadi", "/etc/passwd", "sub/../../ode.casadi"])
def test_files_outside_the_folder_are_refused(folder, value):
    _tamper(folder, lambda r: r["files"].__setitem__("alg", value))
    with pytest.raises(ExportError, match=r"files\['alg'\]"):
        load(folder)


def test_a_link_leaving_the_folder_is_refused(folder, tmp_path):
    outside = tmp_path / "outside.casadi"
    shutil.copy(folder / "alg.casadi", outside)
    (folder / "link.casadi").symlink_to(outside)
    _tamper(folder, lambda r: r["files"].__setitem__("alg", "link.casadi"))
    with pytest.raises(ExportError, match=r"files\['alg'\].*out of the export folder"):
        load(folder)


@pytest.mark.parametrize("change, key", [
    (lambda r: r["files"].pop("ode"), "'ode'"),
    (lambda r: r.pop("x"), "'x'"),
    (lambda r: r.pop("selection"), "'selection'"),
    (lambda r: r["x"].pop(), "'x'"),
    (lambda r: r["p"][0].__setitem__("value", "NaN") if r["p"] else r["x"][0].__setitem__("nominal", None),
     r"\]\["),
    (lambda r: r.__setitem__("files", [1]), "files"),
    (lambda r: r["files"].__setitem__("transition", 3), "transition"),
])
def test_tampered_keys_are_named(folder, change, key):
    _tamper(folder, change)
    with pytest.raises(ExportError, match=key):
        load(folder)


# ---- the SHA-256 of each file, recorded at export: a folder mixing two exports is refused

@pytest.fixture(scope="module")
def other(tmp_path_factory):
    """An export of the same signature (the pendulum 2 m long): its files fit the first one's record."""
    return cartesian_pendulum(L=2.0).compile().export(tmp_path_factory.mktemp("other") / "pendulum")


def test_a_function_of_another_export_is_refused(folder, other):
    assert (other / "alg.casadi").read_bytes() != (folder / "alg.casadi").read_bytes()      # L enters alg
    shutil.copy(other / "alg.casadi", folder / "alg.casadi")
    with pytest.raises(ExportError, match=r"alg\.casadi does not match the SHA-256.*mixes two exports"):
        load(folder)


def test_the_record_of_another_export_is_refused(folder, other):
    shutil.copy(other / "model.json", folder / "model.json")
    with pytest.raises(ExportError, match=r"\.casadi does not match the SHA-256"):
        load(folder)


def test_an_edited_byte_is_refused(folder):
    data = bytearray((folder / "observed.casadi").read_bytes())
    data[len(data) // 2] = ord("a") if data[len(data) // 2] != ord("a") else ord("b")
    (folder / "observed.casadi").write_bytes(bytes(data))
    with pytest.raises(ExportError, match=r"observed\.casadi does not match the SHA-256"):
        load(folder)


def test_an_export_without_digests_loads(folder):
    """Exports written before mechnet recorded digests have no "sha256": they load unchecked."""
    from mechnet.export import ExportWarning
    _tamper(folder, lambda r: r.pop("sha256"))
    with pytest.warns(ExportWarning):
        assert load(folder).record["name"] == "pendulum"


@pytest.mark.parametrize("change, match", [
    (lambda r: r["sha256"].__setitem__("ode.casadi", "0" * 63), r"sha256\['ode\.casadi'\]"),
    (lambda r: r["sha256"].pop("zero.casadi"), r"'sha256'.*zero\.casadi"),
    (lambda r: r.__setitem__("sha256", ["ode.casadi"]), r"'sha256'"),
])
def test_a_tampered_digest_is_named(folder, change, match):
    _tamper(folder, change)
    with pytest.raises(ExportError, match=match):
        load(folder)


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    if compiler() is None:
        pytest.skip("no C compiler on this machine")
    return cartesian_pendulum().compile().export(tmp_path_factory.mktemp("lib") / "pendulum", kind="c")


def test_load_library_checks_the_library(library, tmp_path):
    from mechnet.export import load_library
    folder = shutil.copytree(library, tmp_path / "copy")
    assert "ode" in load_library(folder)
    name = json.loads((folder / "model.json").read_text())["files"]["library"]
    for value in ("../" + name, "/usr/lib/libc.so.6", 3):
        _tamper(folder, lambda r: r["files"].__setitem__("library", value))
        with pytest.raises(ExportError, match=r"files\['library'\]"):
            load_library(folder)
    _tamper(folder, lambda r: r["files"].__setitem__("library", name))
    with open(folder / name, "ab") as f:
        f.write(b"\0")                                  # still a library, not the one exported
    with pytest.raises(ExportError, match=rf"{name} does not match the SHA-256"):
        load_library(folder)
    with pytest.raises(ExportError, match="loads once its entry is deleted from 'sha256'"):
        load_library(folder)
    for table in ("garbage", {name: "x"}):             # a malformed table is refused, as `load` refuses it
        _tamper(folder, lambda r: r.__setitem__("sha256", table))
        with pytest.raises(ExportError, match=r"sha256"):
            load_library(folder)
    _tamper(folder, lambda r: r.__setitem__("sha256", {}))  # one the user rebuilt: its digest removed
    assert "ode" in load_library(folder)
    _tamper(folder, lambda r: r["files"]["functions"].__setitem__("ode", "a; b"))
    with pytest.raises(ExportError, match=r"'files' must hold"):
        load_library(folder)


@pytest.mark.parametrize("path", [None, 3, ["a"]])
def test_a_path_that_is_no_path_is_refused(path):
    from mechnet.export import load_library
    for reader in (load, load_library):
        with pytest.raises(ExportError, match=r"load\(path=.*give the folder"):
            reader(path)
