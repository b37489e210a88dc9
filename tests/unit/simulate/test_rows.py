"""A run's rows: blocks of one selection are observed together; a block that gives its observed values
(an output next to a change point, `ChangePoints._bridge`) is never joined with its neighbours."""
import numpy as np

from mechnet.simulate.rows import Rows


def test_blocks_of_one_selection_join_and_given_values_stay_apart():
    a, b = object(), object()            # two selections
    d = np.zeros(0)
    rows = Rows()
    rows.add(np.array([0.0, 1.0]), np.ones((2, 1)), np.zeros((2, 2)), a, d)
    rows.add_row(2.0, [2.0], [0.0, 0.0], a, d)
    rows.add_row(3.0, [3.0], [0.0, 0.0], a, d, observed=[3.0, 9.0, 9.0, 7.0])
    rows.add_row(4.0, [4.0], [0.0, 0.0], a, d)
    rows.add_row(5.0, [5.0], [0.0, 0.0], b, d)
    parts = list(rows.by_selection())
    assert [(p[0] is a, p[1].tolist(), p[5] is None) for p in parts] == [
        (True, [0.0, 1.0, 2.0], True), (True, [3.0], False), (True, [4.0], True), (False, [5.0], True)]
    assert parts[1][5].tolist() == [[3.0, 9.0, 9.0, 7.0]]
    assert len(rows) == 6 and rows.times().tolist() == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def test_replacing_the_last_row_keeps_the_given_values_of_the_rows_before():
    a, b, d = object(), object(), np.zeros(0)
    rows = Rows()
    rows.add(np.array([0.0, 1.0]), np.ones((2, 1)), np.zeros((2, 1)), a, d, observed=np.array([[1.0], [2.0]]))
    rows.replace_last([5.0], [6.0], b)          # a re-selection at the last recorded time
    parts = list(rows.by_selection())
    assert [(p[0] is a, p[1].tolist(), None if p[5] is None else p[5].tolist()) for p in parts] == [
        (True, [0.0], [[1.0]]), (False, [1.0], None)]
    assert rows.last.x.tolist() == [5.0] and len(rows) == 2


def test_the_last_solved_row_skips_rows_with_given_values():
    a, d = object(), np.zeros(0)
    rows = Rows()
    assert rows.last_solved is None
    rows.add_row(0.0, [1.0], [2.0], a, d)
    rows.add_row(1.0, [3.0], [4.0], a, d, observed=[3.0, 4.0])
    assert rows.last.t == 1.0 and rows.last_solved.t == 0.0 and rows.last_solved.z.tolist() == [2.0]
