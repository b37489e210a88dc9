"""The scene: components, connections between their connectors, nested subsystems.

Connections are edges of a networkx graph whose nodes are connectors; flatten
takes its connected components as connection sets. A `Model` added to another
model is a subsystem: its components get its name as a prefix, and the
connectors it `expose`s can be connected from outside.
"""
from __future__ import annotations

from typing import Union

import networkx as nx

from .component import Component, Connector, _check_name
from .errors import ConnectError, FrozenModelError, NameConflictError, StructureError, UnknownNameError


class NoSuchMember(UnknownNameError, AttributeError):
    """`model.j9` for a name the model does not hold: a mechnet error naming it, and still an AttributeError
    (hasattr and getattr with a default keep working)."""


def _type_label(connector) -> str:
    """'rotational.Flange' for library connectors, 'module.Class' for user-defined ones."""
    parts = type(connector).__module__.split(".")
    domain = parts[-2] if len(parts) >= 2 and parts[0] == "mechnet" else parts[-1]
    return f"{domain}.{type(connector).__name__}"


class Model:
    """A scene under construction; `compile()` freezes it."""

    def __init__(self, name: str):
        self.name = _check_name(name, "Model")
        self.path = name
        self.graph = nx.Graph()
        self._items: dict[str, Union[Component, "Model"]] = {}
        self._exposed: dict[str, Connector] = {}
        self._frozen = False
        self._parent = None

    # ---- building ---------------------------------------------------------------------------

    def _check_open(self, action: str):
        if self._frozen:
            raise FrozenModelError(f"model {self.name!r} was compiled and is frozen: cannot {action}. "
                                   f"Build a new Model (or a fresh copy of the scene) to change it")

    def add(self, item):
        """Add a component or a subsystem (another Model); returns it for chaining."""
        if not isinstance(item, (Component, Model)):
            raise ConnectError(f"model {self.name!r}: add() takes a component or a Model, got {item!r}")
        self._check_open(f"add {item.name!r}")
        if isinstance(item, Model) and (item is self or item._contains_model(self)):
            raise ConnectError(f"model {self.name!r}: cannot add {item.name!r}: a model cannot contain itself "
                               f"(directly or through its subsystems)")
        if item.name in self._items:
            other = self._items[item.name]
            raise NameConflictError(f"model {self.name!r}: a component named {item.name!r} already exists "
                                    f"({type(other).__name__}); every component needs its own name")
        if getattr(item, "_parent", None) is not None:
            raise NameConflictError(f"{item.name!r} is already part of a model; create a new instance")
        if isinstance(item, Model):
            item._parent = self
        else:
            item._parent = self
        self._items[item.name] = item
        self._relabel(item, self._prefix())
        for connector in self._connectors_of(item):
            self.graph.add_node(connector)
        return item

    def _prefix(self) -> str:
        return "" if self._parent is None else self.path + "."

    @staticmethod
    def _relabel(item, prefix: str):
        item.path = prefix + item.name
        if isinstance(item, Model):
            for sub in item._items.values():
                Model._relabel(sub, item.path + ".")

    def connect(self, a: Connector, b: Connector) -> None:
        """Connect two connectors of the same type: potentials equal, flows sum to zero."""
        self._check_open("connect")
        for c in (a, b):
            if hasattr(c, "_message") and not isinstance(c, Connector):
                raise ConnectError(c._message)
            if not isinstance(c, Connector):
                raise ConnectError(f"model {self.name!r}: connect() takes connectors such as "
                                   f"inertia.flange_a, got {c!r}")
            if not self.owns(c.owner):
                raise ConnectError(f"model {self.name!r}: connector {c.label} belongs to a component "
                                   f"that was not added to this model; call model.add() on it first")
        if a is b:
            raise ConnectError(f"connector {a.label} cannot be connected to itself")
        if type(a) is not type(b):
            raise ConnectError(f"cannot connect {a.label} ({_type_label(a)}) to {b.label} ({_type_label(b)}): "
                               f"connectors must be of the same type")
        self.graph.add_edge(a, b)

    def expose(self, name: str, connector: Connector) -> Connector:
        """Make an inner connector reachable as `subsystem.<name>` from the parent model."""
        self._check_open("expose")
        _check_name(name, f"model {self.name!r}")
        if not isinstance(connector, Connector):
            raise ConnectError(f"model {self.name!r}: expose({name!r}, ...) takes a connector such as "
                               f"inertia.flange_a, got {connector!r}")
        if name in self._exposed or name in self._items or hasattr(type(self), name):
            raise NameConflictError(f"model {self.name!r}: cannot expose a connector as {name!r}: the name is "
                                    f"already taken (an exposed connector, a component or a Model method)")
        if not self.owns(connector.owner):
            raise ConnectError(f"model {self.name!r}: cannot expose {connector.label}: not part of this model")
        self._exposed[name] = connector
        return connector

    def __getattr__(self, key):
        exposed = self.__dict__.get("_exposed", {})
        if key in exposed:
            return exposed[key]
        items = self.__dict__.get("_items", {})
        if key in items:
            return items[key]
        raise NoSuchMember(f"model {self.__dict__.get('name')!r} has no component or exposed connector {key!r}")

    # ---- queries ----------------------------------------------------------------------------

    def _contains_model(self, other: "Model") -> bool:
        for item in self._items.values():
            if isinstance(item, Model) and (item is other or item._contains_model(other)):
                return True
        return False

    def owns(self, component) -> bool:
        """True when the component was added to this model or to one of its subsystems."""
        node = getattr(component, "_parent", None)
        while node is not None:
            if node is self:
                return True
            node = node._parent
        return False

    @staticmethod
    def _connectors_of(item):
        if isinstance(item, Model):
            return [c for comp in item.components() for c in comp.ports().values()]
        return list(item.ports().values())

    def components(self) -> list[Component]:
        """All leaf components, depth first, in the order they were added."""
        out = []
        for item in self._items.values():
            out.extend(item.components() if isinstance(item, Model) else [item])
        return out

    def connection_graph(self) -> nx.Graph:
        """Connectors of all leaf components as nodes, connections of every level as edges."""
        g = nx.Graph()
        for comp in self.components():
            g.add_nodes_from(comp.ports().values())
        self._add_edges(g)
        return g

    def _add_edges(self, g: nx.Graph):
        g.add_edges_from(self.graph.edges)
        for item in self._items.values():
            if isinstance(item, Model):
                item._add_edges(g)

    def freeze(self) -> None:
        self._frozen = True
        for item in self._items.values():
            if isinstance(item, Model):
                item.freeze()

    def compile(self, options=None):
        """Run the pipeline (flatten, simplify, analyze, emit); returns a CompiledModel."""
        from ..compile.pipeline import compile_model
        if not self._items:     # compiled to 0 states, which simulated a clock: a forgotten add() (fuzz, issue 32)
            raise StructureError(f"model {self.name!r} has no components: add() them before compile()")
        return compile_model(self, options)

    def __repr__(self):
        return f"<Model {self.name}: {len(self._items)} items>"
