"""help(cm.simulate) lists every keyword setting of the simulator with its default (issue 32, item 7)."""
import ast
import inspect
import re

from mechnet.compile.compiled import CompiledModel
from mechnet.simulate.integrator import simulate


def test_simulate_docstring_lists_every_setting_with_its_default():
    doc = inspect.getdoc(CompiledModel.simulate)
    settings = [p for p in inspect.signature(simulate).parameters.values() if p.kind is p.KEYWORD_ONLY]
    assert len(settings) >= 14
    for p in settings:
        entry = re.search(rf"^{p.name} : (?:.*, )?default (\S+?)(?: \(.*\))?$", doc, re.MULTILINE)
        assert entry, f"help(cm.simulate) does not list {p.name} with its default"
        assert ast.literal_eval(entry.group(1)) == p.default, (p.name, entry.group(1), p.default)
