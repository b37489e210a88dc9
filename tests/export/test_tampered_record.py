"""A tampered model.json is refused by export.load with an ExportError naming the key, never another
exception (issue 32, item 1): every key load reads is deleted, set to a string, a list, a mapping, null and
NaN, and lists and mappings lose or gain an entry; so is every field of each key's first entry. Three
exports cover every kind of entry: a pendulum (algebraic variables), clutch_brake with every parameter
tunable (parameters with checks and requirements, modes, events, time events), a driven inertia (an input).

A few changes leave a record as consistent as one the export could have written (a dropped time event, start
value or guess; a free-text field set to another text); those load, and are listed in ACCEPTED."""
import copy
import json
import math
import re
import shutil
import warnings

import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.export import ExportError, load
from mechnet.scene import load_scene
from models import cartesian_pendulum

EXAMPLES = __import__("pathlib").Path(__file__).parents[2] / "examples"


def _driven():
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=mn.tunable(1.0), phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq"))
    m.connect(tq.flange, j.flange_a)
    return m


def _clutch_brake():
    with mn.every_parameter_tunable():
        return load_scene(EXAMPLES / "clutch_brake.py").model()


MODELS = {"pendulum": cartesian_pendulum, "clutch_brake": _clutch_brake, "driven": _driven}
KEYS = ("format", "kind", "name", "files", "x", "z", "u", "p", "d", "observed", "starts", "declared_starts",
        "guesses", "zero", "time_events", "invariants", "quaternions", "alg_labels", "linear_tears",
        "folded_parameters", "parameter_requirements", "dependencies", "selection", "sha256")
FIELDS = {"x": ("name", "unit", "nominal"), "z": ("name", "unit", "nominal"),
          "u": ("name", "unit", "default", "causality", "variability"),
          "p": ("name", "unit", "value", "causality", "variability", "owner", "doc", "check"),
          "d": ("name", "unit", "start", "variability"), "observed": ("name", "unit", "kind", "nominal"),
          "starts": ("name", "value"), "declared_starts": ("name", "value"),
          "zero": ("label", "direction", "at_start"),
          "parameter_requirements": ("lhs", "lhs_value", "rhs", "rhs_value", "op", "why", "owner"),
          "selection": ("holds", "states", "reason")}
WRONG = {"string": "x", "list": [], "mapping": {}, "null": None, "NaN": math.nan}
MUTATIONS = ("delete", *WRONG, "drop", "add")

# (key, mutation) that leave a record an export could have written: the model's name (free text), optional
# keys (exports written before them),
# entries whose absence cannot be told from the functions (a time event, a start value, a guess, a folded
# parameter's name, a requirement), a repeated time event or requirement, an extra digest or selection field
_DROPPABLE = ("time_events", "declared_starts", "folded_parameters", "parameter_requirements", "linear_tears",
              "quaternions")
ACCEPTED = ({(k, "delete") for k in ("quaternions", "linear_tears", "parameter_requirements", "sha256")}
            | {(k, m) for k in _DROPPABLE for m in ("list", "drop")} | {("guesses", "mapping"), ("guesses", "drop")}
            | {("name", "string"), ("time_events", "add"), ("parameter_requirements", "add"), ("sha256", "add"),
               ("selection", "add")})
# fields load does not read (an FMU writes its own causality and variability), and free text
_UNREAD = ("causality", "variability")
_TEXT = ("unit", "kind", "label", "why", "owner", "doc", "reason")
ACCEPTED_FIELDS = ({(k, f, m) for k in FIELDS for f in _UNREAD for m in MUTATIONS}
                   | {(k, f, "string") for k in FIELDS for f in _TEXT}
                   | {("p", f, "delete") for f in ("owner", "doc", "check")} | {("zero", "at_start", "delete"),
                                                                             ("p", "check", "null")})


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    made = {}

    def get(name):
        if name not in made:
            made[name] = MODELS[name]().compile().export(tmp_path_factory.mktemp(name) / name)
        return made[name]
    return get


def _mutated(value, mutation):
    """`value` changed by `mutation`, or the marker _DELETE."""
    if mutation == "delete":
        return _DELETE
    if mutation in WRONG:
        return copy.deepcopy(WRONG[mutation])
    if not isinstance(value, (list, dict)):
        return None
    value = copy.deepcopy(value)
    if mutation == "drop" and value:
        value.pop(next(iter(value))) if isinstance(value, dict) else value.pop()
    elif mutation == "add":
        if isinstance(value, dict):
            value["nobody"] = copy.deepcopy(next(iter(value.values()))) if value else 0
        else:
            value.append(copy.deepcopy(value[0]) if value else 0)
    return value


_DELETE = object()


def _load_tampered(exported, tmp_path, change):
    """The outcome of loading a copy of `exported` whose model.json `change` edits; None when it changes
    nothing."""
    folder = shutil.copytree(exported, tmp_path / "copy")
    record = json.loads((folder / "model.json").read_text())
    original = copy.deepcopy(record)
    change(record)
    if record == original or (isinstance(record, dict) and json.dumps(record) == json.dumps(original)):
        return None
    (folder / "model.json").write_text(json.dumps(record))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            load(folder)
        except mn.MechnetError as exc:
            return exc
    return "loaded"


def _names(message: str, key: str) -> bool:
    return re.search(rf"'{key}'|\b{key}\[|\b{key}=", message) is not None


@pytest.mark.parametrize("mutation", MUTATIONS)
@pytest.mark.parametrize("key", KEYS)
@pytest.mark.parametrize("model", MODELS)
def test_a_tampered_key_is_refused_naming_it(exports, tmp_path, model, key, mutation):
    def change(record):
        value = _mutated(record.get(key), mutation) if key in record else _DELETE
        if value is _DELETE:
            record.pop(key, None)
        elif value is not None:
            record[key] = value

    outcome = _load_tampered(exports(model), tmp_path, change)
    if outcome is None:
        pytest.skip(f"{mutation} leaves {model}'s {key!r} as it is")
    if (key, mutation) in ACCEPTED:
        assert outcome == "loaded" or _names(str(outcome), key), outcome
    else:
        assert isinstance(outcome, ExportError), f"{key} {mutation}: loaded"
        assert _names(str(outcome), key), str(outcome)


# the lists of entries each export has some of (the others are empty there)
HAS = {"pendulum": ("x", "z", "observed", "starts", "declared_starts", "selection"),
       "clutch_brake": ("x", "p", "d", "observed", "starts", "declared_starts", "zero", "parameter_requirements",
                        "selection"),
       "driven": ("x", "u", "p", "observed", "starts", "declared_starts", "selection")}


@pytest.mark.parametrize("mutation", [m for m in MUTATIONS if m not in ("drop", "add")])
@pytest.mark.parametrize("model, key, field", [(model, k, f) for model, keys in HAS.items() for k in keys
                                                for f in FIELDS[k]])
def test_a_tampered_field_is_refused_naming_its_entry(exports, tmp_path, model, key, field, mutation):
    def change(record):
        holder = record[key] if key == "selection" else (record[key][0] if record[key] else None)
        if holder is None or field not in holder:
            return
        value = _mutated(holder[field], mutation)
        if value is _DELETE:
            del holder[field]
        else:
            holder[field] = value

    outcome = _load_tampered(exports(model), tmp_path, change)
    if outcome is None:
        pytest.skip(f"{model} has no {key}[0][{field!r}] that {mutation} changes")
    if (key, field, mutation) in ACCEPTED_FIELDS:
        assert outcome == "loaded", outcome
    else:
        assert isinstance(outcome, ExportError), f"{key} {field} {mutation}: loaded"
        entry = rf"{key}\['{field}'\]" if key == "selection" else rf"{key}\[0\]\['{field}'\]"
        assert re.search(entry, str(outcome)) or _names(str(outcome), key), str(outcome)


@pytest.mark.parametrize("text, match", [
    ("[1, 2]", "must hold a JSON mapping"),
    ("{}", "has no 'format'"),
    ('{"format": "1"}', r"'format' must be a whole number .* not a string"),
    ('{"format": 1.0}', r"'format' must be a whole number"),
    ('{"format": 0}', r"'format' = 0 is no export format"),
    ('{"format": 99}', "newer mechnet"),
])
def test_the_format_is_said_as_it_is(tmp_path, text, match):
    (tmp_path / "model.json").write_text(text)
    with pytest.raises(ExportError, match=match):
        load(tmp_path)


@pytest.mark.parametrize("change, match", [
    (lambda r: r["p"][0].__setitem__("value", -1.0), r"p\[0\]\['value'\].*motor\.J|J = -1"),
    (lambda r: r["p"][0].__setitem__("value", 1e400), r"p\[0\]\['value'\]"),           # inf
    (lambda r: next(v for v in r["p"] if v["name"] == "clutch.mu_s").__setitem__("value", 0.0),
     r"'parameter_requirements'.*mu_s"),
    (lambda r: r["declared_starts"][0].__setitem__("value", 1e400), r"declared_starts\[0\]\['value'\]"),
    (lambda r: r["d"][0].__setitem__("start", math.nan), r"d\[0\]\['start'\]"),
    (lambda r: r["p"][0].__setitem__("check", "os:system"), r"p\[0\]\['check'\].*no parameter check"),
])
def test_values_outside_their_declared_checks_are_refused_at_load(exports, tmp_path, change, match):
    """(A check named in model.json that mechnet does not have is refused too: an export writes null for a
    check of the user's own.)"""
    outcome = _load_tampered(exports("clutch_brake"), tmp_path, change)
    assert isinstance(outcome, ExportError) and re.search(match, str(outcome)), outcome
