"""pf-holds' compiled path a block of steps at a time: the same random numbers, memory that does not grow.

The backward simulation walks the filter's history from the last step to the first: every particle's
position, yaw error, weight, label and ancestor at every step, ~11 kB a step with 200 particles (4 GB per hour
of 100 Hz), and the whole-run process noise and smoother draws were as much again.  Here the C filter
(``_climbing_c.forward``) runs over blocks of :data:`BLOCK` steps and can resume at any block's start:

* :class:`NoiseBlocks` draws eq 17's process noise for the loop when it reaches a block.  The generator's
  state at the start of every block is recorded by one pass of the same draws beforehand (a normal draw
  consumes a varying number of raw outputs, so a block's start cannot be computed), so each block holds the
  numbers the whole-run draw would have put there.
* :class:`ForwardC` runs the blocks in turn (the filter's outputs) and keeps each block's starting state
  (~30 kB); :func:`smooth_blocks_c` runs them again, last first, and draws the trajectories back through each
  with :class:`sportfusion.estimators.particles.BackwardDraws` (the uniforms by jumping the generator ahead).

The smoother's outputs are those of one backward simulation over the whole history, to the bit; the filter
runs twice (~10 s CPU per hour of 100 Hz).  ``tests/test_climbing_native.py`` checks blocks of 1 and 7 steps
against one block and against the numpy reference (which keeps the whole history).
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


class ForwardC:
    """The C filter's loop (``ext.forward``) over blocks of steps, each resumable from a snapshot of its start.

    The first block runs steps ``k0 .. k0 + block``, each later one ``block`` steps from a noise block's start.
    :meth:`record` runs them all in turn and keeps, per block, the filter's state where it starts (work arrays,
    strata's evidence, the last step's weights: ~30 kB); :meth:`replay` runs one block again from its snapshot,
    with the same noise, so that the backward simulation finds the particles of that block in :attr:`hist`,
    :attr:`w` (row 0: the step before the block), :attr:`lab` and :attr:`anc` (rows: the block's steps).

    Parameters
    ----------
    ext : module
        The C extension ``_climbing_c``.
    head, tail : list
        ``ext.forward``'s arguments before the history buffers and from ``out_pos`` to ``iwork``.
    noise : NoiseBlocks
    n, m, k0 : int
        Steps, particles and the first step filtered.
    buffers : (hist, w, lab, anc), optional
        The history buffers for steps ``k0 .. n - 1`` (``w`` one row more in front): then one block runs over
        them all.  Default: buffers of one block.
    """

    def __init__(
        self, ext: Any, head: list, tail: list, noise: NoiseBlocks, n: int, m: int, k0: int, buffers: tuple | None
    ) -> None:
        self.ext, self.head, self.tail, self.noise, self.n, self.m = ext, head, tail, noise, n, m
        self.start_ev, self.work, self.iwork = tail[5], tail[6], tail[7]
        self.state = np.zeros(6)
        block = noise.block
        starts = [k0] if buffers is not None else [k0, *range(k0 + 1 + block, n, block)]
        self.blocks = list(zip(starts, [*starts[1:], n], strict=True))
        if buffers is None:
            rows = max(b - a for a, b in self.blocks)
            buffers = (np.empty((rows + 1, m, 4)), np.empty((rows + 1, m)), np.empty((rows, m), dtype=np.int64))
            buffers += (np.empty((rows, m), dtype=np.int64),)
        self.hist, self.w, self.lab, self.anc = buffers
        self._snaps: list[tuple[np.ndarray, ...]] = []

    def _run(self, i: int) -> tuple[int, int]:
        kb, ke = self.blocks[i]
        span = ke - kb
        self.anc[:span] = np.arange(self.m)  # the identity where no resampling writes its indices
        nk = self.noise.nk
        return self.ext.forward(
            *self.head, self.hist[:span], self.w[: span + 1], self.lab[:span], self.anc[:span], *self.tail,
            self.noise if nk else None, self.noise.block, kb, ke, self.state,
        )  # fmt: skip

    def record(self) -> tuple[int, int]:
        """Run every block; returns the merge step and the resamplings (as ``ext.forward``)."""
        for i, (kb, ke) in enumerate(self.blocks):
            if len(self.blocks) > 1:
                self._snaps.append((self.work.copy(), self.iwork.copy(), self.start_ev.copy(), self.state.copy()))
                self._snaps[-1] += (self.w[0].copy(),)
            merged, resamples = self._run(i)
            self.w[0] = self.w[ke - kb]  # the weights of the block's last step: row 0 of the next
        self._final = self.start_ev.copy()
        return merged, resamples

    def replay(self, i: int) -> None:
        """Run block ``i`` again from its snapshot (the outputs are written again with the same values)."""
        work, iwork, start_ev, state, w0 = self._snaps[i]
        self.work[:], self.iwork[:], self.start_ev[:], self.state[:], self.w[0] = work, iwork, start_ev, state, w0
        self._run(i)
        self.start_ev[:] = self._final


def smooth_blocks_c(
    fwd: ForwardC,
    model: Any,
    k0: int,
    rng: np.random.Generator,
    moves: int,
    codes: int,
    out: tuple[np.ndarray, np.ndarray, np.ndarray],
    zero: tuple[int, np.ndarray] | None,
) -> np.ndarray:
    """The smoother's most likely cluster per step by backward simulation in C, a block of the filter at a time.

    Each block of ``fwd`` (already recorded) is run again, last first, and the trajectories are drawn back
    through it: the same draws, tests and clusters as one backward simulation over the filter's whole history.

    Parameters
    ----------
    fwd : ForwardC
        The filter, after :meth:`ForwardC.record`.
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
    zero : (stop, losers) or None
        Weights set to zero before smoothing: steps before ``stop``, particles where ``losers`` (m,) is True
        (the strata of the start holds with the smaller evidence).

    Returns
    -------
    numpy.ndarray of int64 (n - k0,)
        The cluster's label code at steps ``k0..n-1``.
    """
    ext, n, m = fwd.ext, fwd.n, fwd.m
    c64 = np.ascontiguousarray
    horiz, kstep, ustep = c64(model.horiz), c64(model.kstep), c64(model.ustep)
    chol, ysig = c64(model.chol), c64(model.yaw_sigma)
    code = np.empty(n, dtype=np.int64)
    hist, lab = fwd.hist, fwd.lab
    draws = j = nxt = None
    for i in range(len(fwd.blocks) - 1, -1, -1):
        kb, ke = fwd.blocks[i]
        span = ke - kb
        if len(fwd.blocks) > 1:
            fwd.replay(i)
        w = fwd.w[1 : span + 1]  # the block's steps
        if zero is not None and zero[0] > kb:
            w[: zero[0] - kb, zero[1]] = 0.0
        if draws is None:  # the last block: the trajectories' ends at the last step
            draws = BackwardDraws(w[span - 1], n - 1 - k0, rng, moves)
            j = c64(draws.end, dtype=np.int64)
            last = slice(n - 1, n)
            ext.path_clusters(1, m, 0, codes, j, hist[span - 1 : span], lab[span - 1 : span], *_rows(out, code, last))
            rows = span - 1  # steps kb .. n - 2
        else:
            hist[span] = nxt  # the particles of step ke, from the block after
            rows = span
        if rows > 0:
            cum, u, log_u = draws.rows(kb - k0, kb + rows - k0, w[:rows])
            path = np.empty((rows + 1, m), dtype=np.int64)
            e = slice(kb, kb + rows)
            ext.backward_paths(
                rows + 1, m, 0, moves, j, cum, c64(u), c64(-2.0 * log_u), fwd.anc[:rows], hist[: rows + 1],
                horiz[e], kstep[e], ustep[e], chol[e], ysig[e], path,
            )  # fmt: skip
            ext.path_clusters(rows, m, 0, codes, path[:-1], hist[:rows], lab[:rows], *_rows(out, code, e))
            j = path[0].copy()
        nxt = hist[0].copy()
    return code[k0:]


def _rows(out: tuple[np.ndarray, ...], code: np.ndarray, rows: slice) -> tuple[np.ndarray, ...]:
    pos, prob, yaw = out
    return pos[rows], code[rows], prob[rows], yaw[rows]
