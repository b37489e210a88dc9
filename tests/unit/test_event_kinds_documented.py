"""Every kind of event the simulator records is in docs/concepts.md's table of Result.events kinds."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def recorded_kinds() -> set:
    """The kinds the simulator's sources pass to Event(t, kind, cause)."""
    kinds = set()
    for path in (ROOT / "src" / "mechnet").rglob("*.py"):
        kinds.update(re.findall(r"\bEvent\([^,()]+(?:\([^()]*\))?,\s*\"([^\"]+)\"", path.read_text(encoding="utf-8")))
    return kinds


def test_the_docs_table_lists_every_event_kind():
    """Issue 32, item 7: "rest" (an accumulation ended in a rest mode) was missing from the table."""
    kinds = recorded_kinds()
    assert {"time", "state", "reselection", "change point", "method", "rest"} <= kinds, kinds
    rows = [line for line in (ROOT / "docs" / "concepts.md").read_text(encoding="utf-8").splitlines()
            if line.startswith("| `kind` |")]
    assert len(rows) == 1, rows
    documented = set(re.findall(r'`"([^"]+)"`', rows[0]))
    assert kinds <= documented, f"not in docs/concepts.md's table of event kinds: {sorted(kinds - documented)}"
