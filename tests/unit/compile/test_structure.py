"""analyze_structure: maximum matching, balance, BLT order and algebraic loops."""
import pytest

import mechnet as mn
from mechnet.compile.alias import simplify
from mechnet.compile.flatten import flatten
from mechnet.compile.structure import analyze_structure, maximum_matching
from stage_scenes import LinearLoop, ReversedChain, single


def assert_valid_matching(matching, incidence, n_unknowns):
    """Each matched equation gets a variable it contains, and no variable is used twice."""
    for e, k in matching.items():
        assert 0 <= e < len(incidence) and 0 <= k < n_unknowns
        assert k in incidence[e], (e, k)
    assert len(set(matching.values())) == len(matching)


@pytest.mark.parametrize("incidence, n_unknowns", [
    ([[0]], 1),
    ([[0, 1], [1, 2], [2]], 3),                 # triangular: forced from the bottom up
    ([[0, 1], [0]], 2),                         # greedy e0 -> 0 must be undone by an augmenting path
    ([[0, 1, 2], [0], [0, 1]], 3),              # augmenting path of length 5
    ([[1], [0, 2], [2, 3], [3, 0]], 4),         # a cycle plus a pendant
], ids=["one", "triangular", "augment", "long-augment", "cycle"])
def test_perfect_matching_is_found(incidence, n_unknowns):
    matching = maximum_matching(incidence, n_unknowns)
    assert_valid_matching(matching, incidence, n_unknowns)
    assert len(matching) == len(incidence) == n_unknowns


@pytest.mark.parametrize("incidence, n_unknowns, size", [
    ([[0], [0]], 2, 1),                         # two equations in one variable, one variable unused
    ([[0, 1], [0, 1], [0, 1]], 3, 2),           # three equations share two variables
    ([[0], [], [1]], 2, 2),                     # an equation with no unknowns cannot be matched
    ([[0, 1]], 3, 1),                           # more unknowns than equations
], ids=["duplicate", "over-determined", "empty-row", "under-determined"])
def test_deficient_matching_is_maximum(incidence, n_unknowns, size):
    matching = maximum_matching(incidence, n_unknowns)
    assert_valid_matching(matching, incidence, n_unknowns)
    assert len(matching) == size


def block_reads_only_earlier_blocks(flat, report):
    """BLT order: every unknown an equation uses is solved in its own block or an earlier one."""
    block_of = {e: b for b, block in enumerate(report.blocks) for e in block}
    solved_in = {report.matching[e]: block_of[e] for e in block_of}
    for e, row in enumerate(report.incidence):
        for k in row:
            if solved_in[k] > block_of[e]:
                return False
    return True


def test_blocks_come_in_dependency_order():
    flat = flatten(single(ReversedChain("c")))           # not simplified: all three equations stay
    report = analyze_structure(flat)
    names = [flat.variables[i].name for i in report.unknowns]
    assert sorted(names) == ["c.y1", "c.y2", "der(c.x)"]
    assert all(len(b) == 1 for b in report.blocks)
    assert sorted(e for b in report.blocks for e in b) == [0, 1, 2]
    solved = [names[report.matching[b[0]]] for b in report.blocks]
    # declared as (der(x) = -y2, y2 = y1 + 1, y1 = x): solved in the reverse order
    assert solved == ["c.y1", "c.y2", "der(c.x)"]
    assert [b[0] for b in report.blocks] == [2, 1, 0]
    assert block_reads_only_earlier_blocks(flat, report)


def test_a_two_by_two_algebraic_loop_is_one_block_of_size_two():
    flat, _ = simplify(flatten(single(LinearLoop("c"))))
    report = analyze_structure(flat)
    sizes = sorted(len(b) for b in report.blocks)
    assert sizes[-1] == 2 and sizes.count(2) == 1
    (loop,) = [b for b in report.blocks if len(b) == 2]
    assert {flat.equations[e].label for e in loop} == {"c (LinearLoop), equation 1", "c (LinearLoop), equation 2"}
    assert {flat.variables[report.unknowns[report.matching[e]]].name for e in loop} == {"c.a", "c.b"}
    # y = a*b reads the loop, so its block comes after it
    (product,) = [e for e, eq in enumerate(flat.equations) if eq.label == "c (LinearLoop), equation 3"]
    position = {e: k for k, b in enumerate(report.blocks) for e in b}
    assert position[product] > position[loop[0]]
    assert block_reads_only_earlier_blocks(flat, report)


def test_the_report_is_consistent_with_the_system():
    flat, _ = simplify(flatten(single(LinearLoop("c"))))
    report = analyze_structure(flat)
    assert report.n_equations == len(flat.equations) == len(report.incidence) == len(report.matching)
    assert tuple(report.unknowns) == tuple(flat.unknowns())
    assert sorted(report.matching) == list(range(len(report.unknowns)))       # perfect
    assert f"{report.n_equations} equations" in report.summary()
    assert f"{len(report.blocks)} BLT blocks (largest 2)" in report.summary()


class Loose(mn.Component):
    """free appears in no equation: one variable too many."""

    x = mn.Var()
    free = mn.Var()

    def equations(self):
        return [mn.Eq(self.x, 1.0, "x is one")]


def test_an_unbalanced_system_names_the_free_variable():
    flat = flatten(single(Loose("c")))
    with pytest.raises(mn.UnbalancedModelError) as info:
        analyze_structure(flat)
    assert any(v.startswith("c.free") for v in info.value.variables)
    assert "c.free" in str(info.value)
