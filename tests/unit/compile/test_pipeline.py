"""compile(): every stage's artifact is kept and summarised; compiling is deterministic."""
import re

import pytest

import mechnet as mn
from mechnet.compile.artifacts import AliasMap, FlatSystem, SemiExplicitDAE, StructureReport
from mechnet.components import rotational as rot
from stage_scenes import Cubic, LinearLoop


def mixed_scene():
    """Something of every kind: springs, a damper, a rigid pair, a source, sensors, a loop, a DAE part."""
    m = mn.Model("mixed")
    fixed = m.add(rot.Fixed("fixed"))
    s1 = m.add(rot.Spring("s1", c=mn.tunable(50.0)))
    j1 = m.add(rot.Inertia("j1", J=0.5, phi_start=0.2, w_start=0.0))
    d12 = m.add(rot.SpringDamper("d12", c=20.0, d=0.3))
    j2 = m.add(rot.Inertia("j2", J=0.7))
    j3 = m.add(rot.Inertia("j3", J=0.4))
    source = m.add(rot.Torque("source", tau=1.0))
    speed = m.add(rot.SpeedSensor("speed"))
    power = m.add(rot.PowerSensor("power"))
    m.connect(fixed.flange, s1.flange_a)
    m.connect(s1.flange_b, j1.flange_a)
    m.connect(j1.flange_b, power.flange_a)
    m.connect(power.flange_b, d12.flange_a)
    m.connect(d12.flange_b, j2.flange_a)
    m.connect(j2.flange_b, j3.flange_a)
    m.connect(source.flange, j3.flange_b)
    m.connect(j3.flange_b, speed.flange)
    m.add(LinearLoop("loop"))
    m.add(Cubic("cubic", x_start=1.0))
    return m


@pytest.fixture(scope="module")
def cm():
    return mixed_scene().compile()


def test_every_stage_artifact_is_kept(cm):
    assert set(cm.stages) == {"flat", "simplified", "aliases", "reduced", "index", "structure", "dae"}
    kinds = {"flat": FlatSystem, "simplified": FlatSystem, "aliases": AliasMap,
             "structure": StructureReport, "dae": SemiExplicitDAE}
    for key, kind in kinds.items():
        assert isinstance(cm.stages[key], kind), key
    assert cm.stages["flat"].stage == "flatten"
    assert cm.stages["simplified"].stage == "simplify"
    assert cm.dae is cm.stages["dae"]


@pytest.mark.parametrize("key, head", [("flat", "flatten:"), ("simplified", "simplify:"),
                                       ("aliases", "simplify:"), ("structure", "structure:"),
                                       ("dae", "emit:")])
def test_every_artifact_summarises_itself(cm, key, head):
    text = cm.stages[key].summary()
    assert isinstance(text, str) and text.startswith(head)


def test_stage_summaries_state_their_counts(cm):
    flat, simplified = cm.stages["flat"], cm.stages["simplified"]
    structure, dae = cm.stages["structure"], cm.stages["dae"]
    assert f"{len(flat.variables)} variables" in flat.summary()
    assert f"{len(flat.equations)} equations" in flat.summary()
    assert f"{len(simplified.equations)} equations" in simplified.summary()
    assert "1 tunable parameters" in flat.summary()
    assert f"{len(structure.blocks)} BLT blocks" in structure.summary()
    assert f"{dae.x.numel()} states, {dae.z.numel()} algebraics" in dae.summary()
    assert f"{dae.n_instructions()} instructions" in dae.summary()


def test_the_model_summary_reports_size_cost_and_effects(cm):
    text = cm.summary()
    for word in ("states", "algebraics", "instructions", "effects"):
        assert word in text, word
    flat, simplified = cm.stages["flat"], cm.stages["simplified"]
    # per-stage equation counts, in pipeline order
    counts = re.search(r"equations: flatten (\d+) -> simplify (\d+) -> emit (\d+) ode \+ (\d+) alg", text)
    assert counts, text
    assert [int(g) for g in counts.groups()] == [len(flat.equations), len(simplified.equations),
                                                 cm.dae.x.numel(), cm.dae.z.numel()]
    assert f"states ({cm.n_states})" in text
    assert f"algebraics ({len(cm.algebraic_names)})" in text
    assert f"{cm.dae.ode.n_instructions()} instructions in ode" in text
    for effect in ("Inertia ×3", "Spring ×1", "SpringDamper ×1", "SpeedSensor ×1", "Cubic ×1"):
        assert effect in text, effect
    assert "index-1 DAE" in text                # the cubic keeps one algebraic


def test_the_mixed_scene_has_the_expected_size(cm):
    # j1 (phi, w); j2 and j3 rigidly joined share one (phi, w); loop.x; cubic.x
    states = set(cm.state_names)
    assert len(cm.state_names) == 6
    assert {"j1.phi", "j1.w", "loop.x", "cubic.x"} <= states
    assert states & {"j2.phi", "j2.w"} == {"j2.phi", "j2.w"} or states & {"j3.phi", "j3.w"} == {"j3.phi", "j3.w"}
    assert cm.algebraic_names == ("cubic.z",)
    assert cm.parameter_names == ("s1.c",)
    assert cm.input_names == ("source.tau",)


def test_compiling_is_deterministic():
    a = mixed_scene().compile()
    b = mixed_scene().compile()
    assert a.state_names == b.state_names
    assert a.algebraic_names == b.algebraic_names
    assert a.names == b.names
    assert a.dae.ode.n_instructions() == b.dae.ode.n_instructions()
    assert a.dae.alg.n_instructions() == b.dae.alg.n_instructions()
    assert a.dae.observed.n_instructions() == b.dae.observed.n_instructions()
    assert [e.label for e in a.stages["simplified"].equations] == [e.label for e in b.stages["simplified"].equations]
    assert a.stages["structure"].blocks == b.stages["structure"].blocks


def test_compile_freezes_the_model():
    m = mixed_scene()
    m.compile()
    with pytest.raises(mn.FrozenModelError):
        m.add(rot.Inertia("late", J=1.0))
