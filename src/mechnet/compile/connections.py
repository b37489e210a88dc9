"""Connection sets: across variables equal, through variables summing to zero."""
from __future__ import annotations

import networkx as nx

from .artifacts import FlatEquation


def _sort_key(connector) -> str:
    return connector.label


def connection_equations(graph: nx.Graph) -> list[FlatEquation]:
    """One equation per across element and pair, one per through element and set.

    A connector nobody connected is a set of one: its flows are zero.
    """
    equations = []
    for members in nx.connected_components(graph):
        members = sorted(members, key=_sort_key)
        names = ", ".join(c.label for c in members)
        first = members[0]
        for key, value in first.across():
            for other in members[1:]:
                for i in range(value.numel()):
                    equations.append(FlatEquation(
                        other._values[key][i] - value[i], "connection",
                        f"connection {{{names}}}: {key} of {other.label} = {key} of {first.label}",
                        "potentials are equal"))
        for key, value in first.through():
            for i in range(value.numel()):
                total = sum((c._values[key][i] for c in members[1:]), value[i])
                what = "sum to zero" if len(members) > 1 else "is zero (unconnected)"
                equations.append(FlatEquation(
                    total, "connection", f"connection {{{names}}}: {key} {what}",
                    "flows sum to zero"))
    return equations
