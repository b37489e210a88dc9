"""Optimal control on a compiled model: describe a `Problem`, solve it with `Collocation` or
`MultipleShooting` (IPOPT through CasADi), replay the `Solution`'s controls with `cm.simulate`."""
from .collocation import Collocation
from .shooting import MultipleShooting
from .problem import OcpError, Problem
from .solution import Solution

__all__ = ["Collocation", "MultipleShooting", "OcpError", "Problem", "Solution"]
