"""A tqdm bar over IPOPT's iterations, fed by nlpsol's iteration callback."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..interrupts import interrupted
from ..solver_output import terminal

SHOW_AFTER_SECONDS = 1.0         # progress=None: a bar only on a terminal, for a solve longer than this


class IterationBar(ca.Callback):
    """Called by IPOPT once per iteration with the iterate (nlpsol's outputs); moves the bar, shows the
    objective and keeps the iterate (`last`: the decision variables, for a solve stopped by Ctrl-C).
    Returns 0 (go on), or 1, a stop request, once Ctrl-C was pressed (`mechnet.interrupts`): CasADi
    swallows the KeyboardInterrupt inside IPOPT's function evaluations, which IPOPT takes for invalid
    numbers."""

    def __init__(self, nx: int, ng: int, np_: int, max_iter: int, progress):
        ca.Callback.__init__(self)
        self.sizes = {"x": nx, "lam_x": nx, "g": ng, "lam_g": ng, "p": np_, "lam_p": np_, "f": 1}
        from tqdm import tqdm
        self.bar = tqdm(total=max_iter, desc="ipopt", unit="it", leave=False, file=terminal(),
                        delay=0.0 if progress else SHOW_AFTER_SECONDS,
                        disable=False if progress else (True if progress is False else None),
                        bar_format="{l_bar}{bar}| {n}/{total} iterations [{elapsed}] {postfix}")
        self.last, self.iterations = None, 0
        self.construct("ipopt_progress", {"enable_fd": False})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.sizes.get(ca.nlpsol_out(i), 0), 1)

    def eval(self, arg):
        try:
            self.last = np.array(arg[ca.nlpsol_out().index("x")], dtype=float).ravel()
            self.iterations += 1
            self.bar.update(1)
            self.bar.set_postfix_str(f"objective {float(arg[ca.nlpsol_out().index('f')]):.6g}", refresh=False)
        except KeyboardInterrupt:               # Ctrl-C right here: noted by `interrupted()`
            if not interrupted():
                raise
        return [1 if interrupted() else 0]

    def close(self):
        self.bar.close()
