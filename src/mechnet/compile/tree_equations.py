"""How the tree pass adds to the equation system: new unknowns and their local equations.

Every row remembers the component it stands for, so a later message can name it.
"""
from __future__ import annotations

import casadi as ca

from .artifacts import FlatEquation, FlatVariable


def defined(tree, comp, names, units, rhs, doc):
    """Unknowns equal to `rhs`, entry by entry; an entry that is exactly zero (a planar scene's
    out-of-plane accelerations and moments) stays the number 0 instead of becoming an unknown."""
    out = []
    for name, unit, value in zip(names, units, ca.vertsplit(ca.densify(ca.SX(rhs)))):
        if value.is_zero():
            out.append(ca.SX(0))
            tree.zeros.append((name, unit))
            continue
        sym = new_unknowns(tree, comp, [name], [unit])
        add_equations(tree, comp, sym - value, doc)
        out.append(sym)
    return ca.vertcat(*out)


def new_unknowns(tree, comp, names, units):
    """Algebraic unknowns of the tree pass, attributed to `comp`."""
    syms = []
    for name, unit in zip(names, units):
        s = ca.SX.sym(name)
        syms.append(s)
        tree.variables.append(FlatVariable(name=name, symbol=s, kind="algebraic", unit=unit, origin=comp.path,
                                           component_type=type(comp).__name__))
    return ca.vertcat(*syms)


def add_equations(tree, comp, residual, doc, regular=False, pivot="", pivot_unless=()):
    """One equation 0 = residual[i] per entry, attributed to `comp`."""
    residual = ca.reshape(ca.SX(residual), -1, 1)
    label = f"{comp.path} ({type(comp).__name__}), tree equation"
    for i in range(residual.numel()):
        tree.equations.append(FlatEquation(residual[i], comp.path, label + (f"[{i}]" if residual.numel() > 1 else ""),
                                           doc, regular=regular, pivot=pivot, pivot_unless=pivot_unless))
