"""load_scene: scene files load by path, and every failure names the file."""
import textwrap
from pathlib import Path

import pytest

from mechnet.core.errors import MechnetError, SceneError
from mechnet.scene import DEFAULT_T_END, Scene, load_scene


def write(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return path


def test_missing_file_names_the_file(tmp_path):
    path = tmp_path / "nowhere.py"
    with pytest.raises(SceneError, match="nowhere.py") as info:
        load_scene(path)
    assert "does not exist" in str(info.value)
    assert isinstance(info.value, MechnetError)


def test_file_without_build_names_the_file(tmp_path):
    path = write(tmp_path, "no_build.py", "t_end = 1.0\n")
    with pytest.raises(SceneError, match="no_build.py") as info:
        load_scene(path)
    assert "build()" in str(info.value)


def test_build_that_is_not_callable(tmp_path):
    path = write(tmp_path, "not_callable.py", "build = 3\n")
    with pytest.raises(SceneError, match="not_callable.py"):
        load_scene(path)


def test_import_failure_names_the_file_and_the_cause(tmp_path):
    path = write(tmp_path, "broken.py", "raise RuntimeError('boom')\n")
    with pytest.raises(SceneError, match=r"broken\.py.*RuntimeError: boom"):
        load_scene(path)


def test_syntax_error_names_the_file(tmp_path):
    path = write(tmp_path, "syntax.py", "def build(:\n")
    with pytest.raises(SceneError, match="syntax.py"):
        load_scene(path)


@pytest.mark.parametrize("t_end", ["-1.0", "0.0", "float('nan')", "'soon'"])
def test_bad_t_end_is_rejected(tmp_path, t_end):
    path = write(tmp_path, "bad_t_end.py", f"t_end = {t_end}\ndef build():\n    return None\n")
    with pytest.raises(SceneError, match="bad_t_end.py.*t_end"):
        load_scene(path)


def test_bad_plot_is_rejected(tmp_path):
    path = write(tmp_path, "bad_plot.py", "plot = [1, 2]\ndef build():\n    return None\n")
    with pytest.raises(SceneError, match="bad_plot.py.*plot"):
        load_scene(path)


def test_attributes_and_defaults(tmp_path):
    path = write(tmp_path, "minimal.py", '''\
        """A minimal scene.

        More text that is not part of the description.
        """
        def build():
            return None
    ''')
    scene = load_scene(path)
    assert isinstance(scene, Scene)
    assert scene.name == "minimal"
    assert scene.path == path.resolve()
    assert scene.t_end == DEFAULT_T_END
    assert scene.reference is None
    assert scene.plot == ()
    assert scene.description == "A minimal scene."


def test_all_optional_attributes(tmp_path):
    path = write(tmp_path, "full.py", '''\
        description = "everything set"
        t_end = 2
        plot = ["j1.phi", "j1.w"]
        def reference(t):
            return {"j1.phi": t}
        def build():
            return None
    ''')
    scene = load_scene(path)
    assert scene.t_end == 2.0 and isinstance(scene.t_end, float)
    assert scene.plot == ("j1.phi", "j1.w")
    assert scene.description == "everything set"
    assert scene.reference(5.0) == {"j1.phi": 5.0}


def test_scene_is_frozen(tmp_path):
    scene = load_scene(write(tmp_path, "frozen.py", "def build():\n    return None\n"))
    with pytest.raises(AttributeError):
        scene.t_end = 1.0


def test_same_stem_loads_as_separate_modules(tmp_path):
    """Two scene files with one stem (or one file loaded twice) must not share module state."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = load_scene(write(tmp_path / "a", "scene.py", "def build():\n    return 'a'\n"))
    second = load_scene(write(tmp_path / "b", "scene.py", "def build():\n    return 'b'\n"))
    assert first.build() == "a" and second.build() == "b"
    assert first.build.__module__ != second.build.__module__


def test_model_rejects_a_non_model(tmp_path):
    pytest.importorskip("mechnet.core.model")
    scene = load_scene(write(tmp_path, "returns_none.py", "def build():\n    return None\n"))
    with pytest.raises(SceneError, match=r"returns_none\.py.*NoneType.*mechnet\.Model"):
        scene.model()


@pytest.mark.parametrize("fails", [False, True])
def test_a_scene_imports_a_helper_module_beside_it(tmp_path, fails):
    """Issue 32, item 7: `import helper` in a scene failed; its folder is on sys.path while it loads, then not."""
    import sys

    module = f"_mechnet_test_helper_{'fails' if fails else 'ok'}"
    write(tmp_path, f"{module}.py", "VALUE = 42\n")
    body = f"import {module}\nt_end = {module}.VALUE\n" + ("raise RuntimeError('boom')\n" if fails else "")
    path = write(tmp_path, "uses_helper.py", body + "def build():\n    return None\n")
    before = list(sys.path)
    try:
        if fails:
            with pytest.raises(SceneError, match="boom"):
                load_scene(path)
        else:
            assert load_scene(path).t_end == 42
    finally:
        sys.modules.pop(module, None)
    assert sys.path == before
