"""cm.export(..., overwrite=True) and `mechnet export --overwrite` replace only a previous mechnet export
(issue 32, item 2): never the working directory, its parents, or a folder holding other files; an
interrupted export leaves the previous one in place and no temporary folder behind."""
import json
from pathlib import Path

import pytest

import mechnet as mn
from mechnet.cli import main
from mechnet.components import rotational as rot
from mechnet.export import ExportError, compiler, files

OSCILLATOR = Path(__file__).resolve().parents[2] / "examples" / "two_inertia_oscillator.py"


@pytest.fixture(scope="module")
def cm():
    m = mn.Model("osc")
    fixed, spring = m.add(rot.Fixed(name="fixed")), m.add(rot.Spring(name="spring", c=100.0))
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    return m.compile()


def listing(folder):
    return sorted(p.name for p in Path(folder).iterdir())


def test_a_folder_with_a_foreign_file_is_refused_and_kept(tmp_path, cm):
    target = tmp_path / "out"
    target.mkdir()
    (target / "keep.txt").write_text("mine")
    with pytest.raises(ExportError, match=r"out holds files and no model.json.*nothing was deleted"):
        cm.export(target, overwrite=True)
    assert (target / "keep.txt").read_text() == "mine"
    # a previous export with a file of the user's added is not an export any more
    cm.export(tmp_path / "prev")
    (tmp_path / "prev" / "notes.md").write_text("mine")
    with pytest.raises(ExportError, match=r"holds files an export did not write \(notes.md\)"):
        cm.export(tmp_path / "prev", overwrite=True)
    assert (tmp_path / "prev" / "notes.md").read_text() == "mine"
    assert listing(tmp_path) == ["out", "prev"]


@pytest.mark.parametrize("where", [".", "..", "parent-abs"])
def test_the_working_directory_and_its_parents_are_refused(tmp_path, monkeypatch, cm, where):
    work = tmp_path / "work"
    work.mkdir()
    cm.export(work / "previous")              # even a folder that holds an export among other things
    (work / "scene.py").write_text("# mine")
    monkeypatch.chdir(work)
    path = tmp_path if where == "parent-abs" else Path(where)
    with pytest.raises(ExportError, match="working directory") as error:
        cm.export(path, overwrite=True)
    assert str(path) in str(error.value)
    assert (work / "scene.py").read_text() == "# mine" and (work / "previous" / "model.json").is_file()
    assert listing(work) == ["previous", "scene.py"] and listing(tmp_path) == ["work"]


def test_a_previous_export_is_replaced(tmp_path, cm):
    target = cm.export(tmp_path / "out")
    (target / "model.json").write_text(json.dumps({**json.loads((target / "model.json").read_text()),
                                                   "name": "old"}))
    assert cm.export(target, overwrite=True) == target
    assert json.loads((target / "model.json").read_text())["name"] == "osc"
    assert listing(tmp_path) == ["out"]                 # no temporary or old folder left beside it
    empty = tmp_path / "empty"
    empty.mkdir()
    cm.export(empty, overwrite=True)                    # an empty folder holds nothing to lose
    assert (empty / "model.json").is_file()
    mn.export.load(target).simulate(0.1)


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
def test_a_previous_c_export_and_fmu_are_replaced_others_refused(tmp_path, cm):
    target = cm.export(tmp_path / "c", kind="c")
    cm.export(target, kind="casadi", overwrite=True)    # one kind over another: both are exports
    assert json.loads((target / "model.json").read_text())["kind"] == "casadi"
    fmu = cm.export(tmp_path / "m.fmu", kind="fmu")
    assert cm.export(fmu, kind="fmu", overwrite=True) == fmu
    other = tmp_path / "other.fmu"
    other.write_bytes(b"not an archive")
    with pytest.raises(ExportError, match="not an FMU"):
        cm.export(other, kind="fmu", overwrite=True)
    assert other.read_bytes() == b"not an archive"
    assert listing(tmp_path) == ["c", "m.fmu", "other.fmu"]


def test_an_interrupted_export_leaves_the_previous_one(tmp_path, cm, monkeypatch):
    target = cm.export(tmp_path / "out")
    before = {p.name: p.read_bytes() for p in target.iterdir()}

    def fail(fns, path):
        (path / "ode.casadi").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(files, "write_casadi", fail)
    with pytest.raises(KeyboardInterrupt):
        cm.export(target, overwrite=True)
    assert {p.name: p.read_bytes() for p in target.iterdir()} == before
    with pytest.raises(KeyboardInterrupt):
        cm.export(tmp_path / "new")                     # a first export interrupted: nothing at all
    assert listing(tmp_path) == ["out"]
    monkeypatch.undo()
    cm.export(tmp_path / "new")                         # the next try is not blocked
    assert (tmp_path / "new" / "model.json").is_file()


def test_cli_dot_overwrite_refuses_and_deletes_nothing(tmp_path, monkeypatch, capsys):
    scene = tmp_path / "scene.py"
    scene.write_text(OSCILLATOR.read_text())
    monkeypatch.chdir(tmp_path)
    assert main(["export", "scene.py", "--kind", "casadi", "-o", ".", "--overwrite"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "\n" not in err
    assert "--overwrite" in err and "working directory" in err and "overwrite=True" not in err
    assert listing(tmp_path) == ["scene.py"] and scene.read_text() == OSCILLATOR.read_text()


def test_cli_names_its_flag(tmp_path, capsys):
    out = tmp_path / "taken"
    out.mkdir()
    (out / "x.txt").write_text("")
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "pass --overwrite" in err and "overwrite=True" not in err
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "-o", str(out), "--overwrite"]) == 2
    assert "holds files and no model.json" in capsys.readouterr().err
    assert listing(out) == ["x.txt"]


def test_sources_kept_without_a_compiler_are_named_at_their_place(tmp_path, cm, monkeypatch):
    monkeypatch.setattr(files, "compiler", lambda: None)
    with pytest.raises(ExportError, match="no C compiler") as error:
        cm.export(tmp_path / "c", kind="c")
    assert f"in {tmp_path / 'c'}" in str(error.value) and "mechnet-tmp" not in str(error.value)
    assert listing(tmp_path) == ["c"] and (tmp_path / "c" / "osc.c").is_file()
    monkeypatch.undo()
    if compiler() is not None:
        cm.export(tmp_path / "c", kind="c", overwrite=True)   # a sources-only export is replaceable
        assert (tmp_path / "c" / "libosc.so").is_file()


def test_cli_accuracy_out_a_file_is_refused_before_the_study(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.write_text("mine")
    assert main(["accuracy", str(OSCILLATOR), "-o", str(taken)]) == 2
    assert "is a file" in capsys.readouterr().err and taken.read_text() == "mine"


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
def test_a_user_file_named_like_a_c_symbol_is_not_the_exports(tmp_path, cm):
    """A kind="c" export lists its C symbol names under files.functions; a user's file of such a name
    beside the export is not one of its files, so overwrite refuses (it was deleted)."""
    target = cm.export(tmp_path / "c", kind="c")
    symbol = next(iter(json.loads((target / "model.json").read_text())["files"]["functions"].values()))
    (target / symbol).write_text("USER DATA")
    with pytest.raises(ExportError, match="holds files an export did not write"):
        cm.export(target, kind="c", overwrite=True)
    assert (target / symbol).read_text() == "USER DATA"


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
def test_a_failed_build_keeps_the_previous_c_export(tmp_path, cm, monkeypatch):
    """The compiler failing on the re-export leaves the previous export, library included."""
    target = cm.export(tmp_path / "c", kind="c")
    before = {p.name: p.read_bytes() for p in target.iterdir()}
    monkeypatch.setenv("CC", "false")
    with pytest.raises(ExportError, match="keeps the previous export"):
        cm.export(target, kind="c", overwrite=True)
    assert {p.name: p.read_bytes() for p in target.iterdir()} == before


def test_a_swap_that_cannot_finish_keeps_the_previous_export(tmp_path, cm, monkeypatch):
    """The new export's rename failing after the previous one was moved aside, with the path made again
    meanwhile (a parallel export): the previous export is kept, named in the error, not removed."""
    target = cm.export(tmp_path / "out")
    before = {p.name: p.read_bytes() for p in target.iterdir()}
    real, calls = files.os.replace, []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:                       # the new export's rename: something made the path again
            Path(dst).mkdir()
            (Path(dst) / "other").write_text("x")
            raise OSError(39, "Directory not empty")
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(ExportError, match="it is kept in") as error:
        cm.export(target, overwrite=True)
    monkeypatch.undo()
    kept = Path(str(error.value).rsplit("it is kept in ", 1)[1])
    assert {p.name: p.read_bytes() for p in kept.iterdir()} == before
