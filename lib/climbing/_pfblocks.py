"""pf-holds' compiled path a block of steps at a time: the same random numbers, a fraction of the memory.

The particle filter's history (every particle's position, yaw error, weight, label and ancestor at every step)
is what the backward simulation needs, about 11 kB a step with 200 particles (4 GB per hour of 100 Hz).  The
rest of what the whole-run arrays of :func:`sportfusion.climbing.particles.run_particle_filter` held -- the
process noise of every step and particle (6.4 kB a step), the backward simulation's cumulative weights,
uniforms, thresholds and trajectories (8 kB a step) -- is drawn and used here a block of steps at a time:

* :class:`NoiseBlocks` draws eq 17's process noise for the C filter's loop when the loop reaches a block.  The
  generator's state at the start of every block is recorded by one pass of the same draws beforehand (the
  normal draws consume a varying number of raw outputs, so a block's start cannot be computed), so each block
  holds the numbers the whole-run draw would have put there.
* :func:`smooth_clusters_c` runs the backward simulation's C paths and their clusters from the last step down,
  a block at a time, with :class:`sportfusion.estimators.particles.BackwardDraws` (uniforms by jumping the
  generator ahead): the trajectories and outputs of the whole-run call, to the bit.

``tests/test_climbing_native.py`` checks both against the numpy reference with small blocks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sportfusion.estimators.particles import BackwardDraws

#: steps per block of the filter's noise and of the smoother (a block's arrays: ~32 kB a step for 200 particles)
BLOCK = 2048


def _generator_at(state: dict, kind: type) -> np.random.Generator:
    bg = kind()
    bg.state = state
    return np.random.Generator(bg)


class NoiseBlocks:
    """Eq 17's process noise, a block of steps at a time, as the whole-run draws would give it.

    The whole-run draws are ``normal = rng.standard_normal((nk, m, 3))`` then
    ``rng.standard_normal((nk, m)) * yaw_sigma[:, None]``; after construction ``rng`` stands where they leave it.

    Parameters
    ----------
    rng : numpy.random.Generator
    nk, m : int
        Steps with noise and particles.
    yaw_sigma : numpy.ndarray (nk,)
        The yaw error's 1-sigma per step [rad].
    block : int
        Steps per block.
    """

    def __init__(self, rng: np.random.Generator, nk: int, m: int, yaw_sigma: np.ndarray, block: int) -> None:
        self.block, self.nk, self.yaw_sigma = block, nk, yaw_sigma
        rows = min(block, nk)
        self.normal = np.empty((rows, m, 3))
        self.psi = np.empty((rows, m))
        self._kind = type(rng.bit_generator)
        self._states: list[tuple[dict, dict]] = []
        starts = range(0, nk, block)
        normal_states = []
        for j in starts:  # the position noise first, then the yaw noise: the whole-run order
            normal_states.append(rng.bit_generator.state)
            rng.standard_normal(out=self.normal[: min(block, nk - j)])
        for a, j in zip(normal_states, starts, strict=True):
            self._states.append((a, rng.bit_generator.state))
            rng.standard_normal(out=self.psi[: min(block, nk - j)])

    def __call__(self, j: int) -> None:
        """Fill :attr:`normal` and :attr:`psi` with the noise of steps ``j .. j + block - 1`` (``j`` a block start)."""
        c = min(self.block, self.nk - j)
        a, b = self._states[j // self.block]
        _generator_at(a, self._kind).standard_normal(out=self.normal[:c])
        _generator_at(b, self._kind).standard_normal(out=self.psi[:c])
        self.psi[:c] *= self.yaw_sigma[j : j + c, None]


def smooth_clusters_c(
    ext: Any,
    state: np.ndarray,
    w: np.ndarray,
    lab: np.ndarray,
    anc: np.ndarray,
    model: Any,
    k0: int,
    rng: np.random.Generator,
    moves: int,
    codes: int,
    out: tuple[np.ndarray, np.ndarray, np.ndarray],
    block: int = BLOCK,
) -> np.ndarray:
    """The smoother's most likely cluster per step by backward simulation in C (``ext``), a block at a time.

    Parameters
    ----------
    ext : module
        The C extension ``_climbing_c``.
    state : numpy.ndarray (n, m, 4)
        The particles' positions [m] and yaw errors [rad] per step.
    w : numpy.ndarray (n, m)
        The filter's weights (within the followed stratum; rows before ``k0`` unused).
    lab : numpy.ndarray of int64 (n, m)
        The particles' label codes.
    anc : numpy.ndarray of int64 (n - 1, m)
        Ancestors (see :func:`sportfusion.estimators.particles.backward_simulation`).
    model : climbing.particles._Model
        Eq 17's steps, noise factors and yaw 1-sigma.
    k0 : int
        First step smoothed (n - 1 > k0).
    rng : numpy.random.Generator
    moves : int
        Metropolis-Hastings moves per trajectory and step.
    codes : int
        Number of label codes.
    out : (pos (n, 3), prob (n,), yaw (n,))
        Filled on rows ``k0..n-1``: the cluster's mean position [m], probability and mean yaw error [rad].
    block : int
        Steps per block.

    Returns
    -------
    numpy.ndarray of int64 (n - k0,)
        The cluster's label code at steps ``k0..n-1``.
    """
    n, m = w.shape
    pos, prob, yaw = out
    c64 = np.ascontiguousarray
    horiz, kstep, ustep = c64(model.horiz), c64(model.kstep), c64(model.ustep)
    chol, ysig = c64(model.chol), c64(model.yaw_sigma)
    draws = BackwardDraws(w, rng, k0, moves)
    code = np.empty(n, dtype=np.int64)
    j = c64(draws.end, dtype=np.int64)
    ext.path_clusters(n, m, n - 1, codes, j, state, lab, pos, code, prob, yaw)  # the trajectories' ends
    hi = n - 2
    while hi >= k0:
        lo = max(k0, hi - block + 1)
        cum, u, log_u = draws.rows(lo - k0, hi + 1 - k0)
        path = np.empty((hi + 2 - lo, m), dtype=np.int64)
        ext.backward_paths(
            hi + 2, m, lo, moves, j, cum, c64(u), c64(-2.0 * log_u), anc[: hi + 1], state[: hi + 2],
            horiz[: hi + 1], kstep[: hi + 1], ustep[: hi + 1], chol[: hi + 1], ysig[: hi + 1], path,
        )  # fmt: skip
        e = hi + 1
        ext.path_clusters(e, m, lo, codes, path[:-1], state[:e], lab[:e], pos[:e], code[:e], prob[:e], yaw[:e])
        j = path[0].copy()
        hi = lo - 1
    return code[k0:]
