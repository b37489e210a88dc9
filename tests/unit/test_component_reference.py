"""Generated signatures, docstrings and docs/components.md tell the truth about the constructors.

A component's `__init__` is `(name, **kwargs)`; the signature, `help()` and the
reference are generated from the declarations. These tests construct every
library component with every keyword its signature shows, check the defaults
against what construction really uses, and keep docs/components.md and the
calls written in the docs in step with the code.
"""
import inspect
import pydoc
import re
from pathlib import Path

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.core.declarations import Flag, Input, Param, Variable
from mechnet.core.reference import COMMAND, component_reference, components

ROOT = Path(__file__).resolve().parents[2]
DOMAINS = {"rot": rot, "tr": tr, "mb": mb}
CONCRETE = [(alias, cls) for alias, module in DOMAINS.items() for cls in components(module)]
IDS = [f"{alias}.{cls.__name__}" for alias, cls in CONCRETE]
SUFFIX_VALUES = {"_start": 0.25, "_guess": 0.5, "_nominal": 2.0}


def keywords(cls) -> dict[str, inspect.Parameter]:
    return {k: p for k, p in inspect.signature(cls).parameters.items() if k != "name"}


def variable_of(cls, key: str):
    """'phi' for 'phi_start' (also _guess, _nominal) when phi is a variable of cls, else None."""
    for suffix in SUFFIX_VALUES:
        if key.endswith(suffix) and isinstance(cls._declarations.get(key[:-len(suffix)]), Variable):
            return key[:-len(suffix)]
    return None


def required_value(decl: Param, key: str = ""):
    """A value every library check accepts (> 0, non-zero, not the zero vector, a lower limit below its
    upper one) in the declared shape."""
    if key.endswith("_min"):
        return -1.0
    return 1.0 if decl.shape == 1 else [1.0, 0.0, 0.0]


def required_arguments(cls) -> dict:
    return {k: required_value(d, k) for k, d in cls._declarations.items() if isinstance(d, Param) and d.default is None}


def sample_arguments(cls) -> dict:
    """A valid value for every keyword the signature shows: flags switched on, start/guess/nominal set to
    recognisable numbers, everything else its default (required parameters a valid value)."""
    args = {}
    for key, p in keywords(cls).items():
        if variable_of(cls, key):
            args[key] = SUFFIX_VALUES[key[len(variable_of(cls, key)):]]
        elif isinstance(cls._declarations.get(key), Flag):
            args[key] = True
        elif p.default is inspect.Parameter.empty:
            args[key] = required_value(cls._declarations[key], key)
        else:
            args[key] = p.default
    return args


def consumed_by_init(cls) -> set[str]:
    """What Component.__init__ pops, read independently from the declarations (its rules: parameters,
    flags, inputs, and start/guess/nominal of every variable), plus a subclass's own explicit arguments."""
    names = set()
    for key, decl in cls._declarations.items():
        if isinstance(decl, (Param, Flag, Input)):
            names.add(key)
        if isinstance(decl, Variable):
            names |= {key + s for s in SUFFIX_VALUES}
    own = list(inspect.signature(cls.__init__).parameters.values())[2:]     # after self, name
    return names | {p.name for p in own if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}


# ---- signatures --------------------------------------------------------------------------------------

def test_signature_shows_parameters_not_kwargs():
    sig = inspect.signature(rot.Inertia)
    assert list(sig.parameters) == ["name", "J", "phi_start", "phi_guess", "phi_nominal",
                                    "w_start", "w_guess", "w_nominal", "a_start", "a_guess", "a_nominal"]
    assert sig.parameters["J"].kind is inspect.Parameter.KEYWORD_ONLY
    assert sig.parameters["J"].default is inspect.Parameter.empty, "a required parameter has no default"
    assert inspect.signature(mb.Revolute).parameters["n"].default == [0.0, 0.0, 1.0]
    assert inspect.signature(mb.Revolute).parameters["use_flange"].default is False


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_signature_is_name_then_keywords(alias, cls):
    params = list(inspect.signature(cls).parameters.values())
    assert params[0].name == "name"
    assert all(p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params), "no **kwargs catch-all"


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_signature_names_are_what_init_consumes(alias, cls):
    assert set(keywords(cls)) == consumed_by_init(cls)


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_every_keyword_in_the_signature_is_accepted_and_used(alias, cls):
    args = sample_arguments(cls)
    inspect.signature(cls).bind("x", **args)
    component = cls("x", **args)                      # an unknown keyword would raise ParameterError
    for info in component.variables():
        if info.local_name in cls._declarations:     # the component's own variables, not its connectors'
            assert np.all(info.start == 0.25) and np.all(info.guess == 0.5) and np.all(info.nominal == 2.0)
    for key, decl in cls._declarations.items():
        if isinstance(decl, Flag):
            assert getattr(component, key) is True


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_signature_defaults_are_the_defaults_used(alias, cls):
    component = cls("x", **required_arguments(cls))
    infos = {info.local_name: info for info in component.variables()}
    for key, p in keywords(cls).items():
        decl = cls._declarations.get(key)
        if isinstance(decl, (Param, Flag)) and p.default is not inspect.Parameter.empty:
            assert np.allclose(np.ravel(np.array(getattr(component, key), dtype=float)), np.ravel(p.default)), key
        elif isinstance(decl, Input):
            assert component.input_defaults[key] == p.default
        elif key.endswith("_nominal"):
            assert np.all(infos[key[:-len("_nominal")]].nominal == p.default), key
        elif key.endswith(("_start", "_guess")):
            assert p.default is None


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_required_parameters_are_refused_when_missing(alias, cls):
    for key, p in keywords(cls).items():
        if p.default is inspect.Parameter.empty:
            others = {k: v for k, v in required_arguments(cls).items() if k != key}
            with pytest.raises(mn.ParameterError, match=rf"parameter {key} is required"):
                cls("x", **others)


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_unknown_keyword_is_refused_and_the_valid_ones_listed(alias, cls):
    with pytest.raises(mn.ParameterError, match="unknown argument") as info:
        cls("x", **required_arguments(cls), no_such_keyword=1.0)
    listed = str(info.value).split("valid arguments are ")[1]
    assert listed == (", ".join(keywords(cls)) or "none")


def test_user_component_with_its_own_init():
    """A subclass that adds an explicit argument before **kwargs shows it, then the declared keywords."""

    class Motor(rot.PartialOneFlange):
        tau_max = mn.Param(1.0, unit="N*m", doc="torque limit", check=mn.positive)

        def equations(self):
            return [mn.Eq(self.flange.tau, -self.tau_max)]

    class GainMotor(Motor):
        def __init__(self, name, gain=2.0, **kwargs):
            self.gain = gain
            super().__init__(name, **kwargs)

    assert str(inspect.signature(GainMotor)) == "(name, gain=2.0, *, tau_max=1.0)"
    assert GainMotor("m", gain=3.0, tau_max=0.5).tau_max == 0.5
    assert "tau_max : N*m, default 1.0\n    torque limit; must be > 0" in GainMotor.__doc__
    assert inspect.signature(rot.PartialOneFlange) == inspect.signature(mn.Component), "abstract bases keep theirs"


# ---- docstrings and help() -----------------------------------------------------------------------------

def test_help_shows_signature_defaults_units_and_checks():
    text = pydoc.render_doc(mb.Revolute, renderer=pydoc.plaintext)
    assert "Revolute(name: str, *, n=[0.0, 0.0, 1.0], use_flange=False, phi_start=None" in text
    assert "Rotation of frame_b about the axis n" in text, "the class's own docstring comes first"
    assert "n : 3-vector, default [0.0, 0.0, 1.0]" in text
    assert "must not be the zero vector" in text
    assert "phi : rad, state" in text and "only with use_flange=True" in text
    inertia = rot.Inertia.__doc__
    assert inertia.startswith("Rigid rotor")
    assert "J : kg*m^2, required\n    moment of inertia about the axis; must be > 0" in inertia


@pytest.mark.parametrize("alias, cls", CONCRETE, ids=IDS)
def test_docstring_names_every_keyword(alias, cls):
    doc = cls.__doc__
    for key in keywords(cls):
        named = variable_of(cls, key) or key
        assert f"\n{named} : " in doc, f"{cls.__name__}.__doc__ does not describe {named}"
    if any(isinstance(d, Variable) for d in cls._declarations.values()):
        assert "`v_start=`" in doc and "`v_guess=`" in doc and "`v_nominal=`" in doc


# ---- docs ----------------------------------------------------------------------------------------------

def test_component_reference_is_up_to_date():
    written = (ROOT / "docs" / "components.md").read_text(encoding="utf-8")
    assert written == component_reference(), (
        f"docs/components.md is out of date with the component declarations; regenerate it with `{COMMAND}`")


def test_component_reference_covers_every_component_and_argument():
    text = component_reference()
    sections = dict(re.findall(r"^### (\S+)\n(.*?)(?=^### |^## |\Z)", text, flags=re.M | re.S))
    assert sorted(sections) == sorted(IDS)
    for alias, cls in CONCRETE:
        rows = set(re.findall(r"^\| `(\w+)` \|", sections[f"{alias}.{cls.__name__}"], flags=re.M))
        assert rows == {k for k in keywords(cls) if not variable_of(cls, k)}, cls.__name__
    assert "| `tau_constant` | parameter | required | `N*m` |" in sections["rot.ConstantTorque"]


def component_calls(text: str):
    """(alias or None, class name, top-level keyword names) of every `Class(...)` call in a text."""
    for match in re.finditer(r"\b(?:(rot|tr|mb)\.)?([A-Z]\w*)\(", text):
        depth, end = 1, match.end()
        while depth and end < len(text):
            depth += {"(": 1, ")": -1}.get(text[end], 0)
            end += 1
        inner = text[match.end():end - 1]
        while re.search(r"\([^()]*\)|\[[^\[\]]*\]", inner):           # drop nested calls and lists
            inner = re.sub(r"\([^()]*\)|\[[^\[\]]*\]", "", inner)
        yield match.group(1), match.group(2), re.findall(r"\b(\w+)\s*=(?!=)", inner)


@pytest.mark.parametrize("doc", ["docs/conventions.md", "docs/concepts.md", "README.md"])
def test_component_calls_in_the_docs_use_real_arguments(doc):
    checked = 0
    for alias, name, used in component_calls((ROOT / doc).read_text(encoding="utf-8")):
        modules = [DOMAINS[alias]] if alias else list(DOMAINS.values())
        candidates = [getattr(m, name) for m in modules if name in getattr(m, "__all__", [])]
        candidates = [c for c in candidates if isinstance(c, type) and issubclass(c, mn.Component)]
        if not candidates:
            continue                                  # Model(...), signals, numpy calls: not components
        for key in used:
            assert any(key in inspect.signature(c).parameters for c in candidates), (
                f"{doc}: {name}(..., {key}=...) but {name} takes no argument {key}; "
                f"see docs/components.md")
        checked += 1
    if doc == "docs/conventions.md":
        assert checked >= 2, "the worked example in conventions.md was not found"


def test_component_calls_parser_finds_nested_keywords():
    calls = list(component_calls('rot.Torque(name="tq", tau=Step(2.0, start_time=1.0)) mb.Body(m=1, I=[[1]])'))
    assert ("rot", "Torque", ["name", "tau"]) in calls
    assert ("mb", "Body", ["m", "I"]) in calls
