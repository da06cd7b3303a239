"""The local policy's greedy scores without torch's module calls (issue 38): one decision of the shipped policy.

:class:`~bimrobot.planning.learned.LearnedPolicy` scores a decision of a policy that reads the local
observation (not advised) with :class:`LocalForward`: the arithmetic of
:class:`~bimrobot.planning.learned.DispatchExtractor`'s ``embed``, ``pair_logits`` and ``wait_logit`` on
one observation (batch 1). The layers over every observed node stay torch's matrix products (one call
each, ``torch.addmm`` as ``nn.Linear`` calls it); the rest is compiled loops (numba): symlog, with the
columns that never change in an episode scaled once per episode; the message passing's means over the
predecessors and successors; the robots, the context, the wait and every pair's two-layer score. At a few
hundred observed nodes and width 32 the arithmetic is small, so torch's cost per call (module calls,
gathers and scatters, as large as the arithmetic: docs/evidence/planning.md) is what this saves.

The logits equal torch's up to float32 rounding (other orders of additions); the greedy choice is the
valid action of the highest logit, as torch's. ``tests/planning/test_learned.py`` checks both: the logits
within 1e-4 of torch's and the choice sb3-contrib's at every decision of two frames.
Times in seconds, positions in metres, masses in kg (the observation's units, scaled by ``symlog``).
"""

from __future__ import annotations

import numpy as np
import torch as th

from bimrobot.planning.dispatch import NODE_FEATURES
from bimrobot.planning.dispatch_observation import _compiled

#: the node feature columns that change during an episode (the state one-hot and the earliest start)
CHANGING = (NODE_FEATURES.index("is_waiting"), NODE_FEATURES.index("earliest_start_s") + 1)
#: the fewest rows for which torch's matrix product (one thread) gives each row the bits it has in a larger
#: batch (measured here: 1 to 3 rows take another path, with other rounding)
MIN_ROWS = 4


def _symlog_rows(x: np.ndarray) -> np.ndarray:
    """Compiled by numba (:func:`_symlog`): sign(x) log(1 + |x|) of a float32 array (rows x columns), the
    logarithm skipped for the zeros (most of the one-hot columns)."""
    rows, columns = x.shape
    out = np.zeros((rows, columns), np.float32)
    for i in range(rows):
        for j in range(columns):
            v = x[i, j]
            if v > 0:
                out[i, j] = np.log1p(v)
            elif v < 0:
                out[i, j] = -np.log1p(-v)
    return out


def _symlog():
    """:func:`_symlog_rows` compiled."""
    return _compiled(_symlog_rows)


def _observed_rows(static: np.ndarray, features: np.ndarray, nodes: np.ndarray, first: int, last: int) -> np.ndarray:
    """Compiled by numba (:func:`_node_rows`): symlog of ``features``' rows ``nodes``, with the columns
    outside ``first:last`` (those that never change in an episode) copied from ``static``, their symlog
    computed once per episode."""
    out = np.empty((nodes.shape[0], features.shape[1]), np.float32)
    for i in range(nodes.shape[0]):
        v = nodes[i]
        for j in range(features.shape[1]):
            if first <= j < last:
                x = features[v, j]
                out[i, j] = np.log1p(x) if x > 0 else (-np.log1p(-x) if x < 0 else np.float32(0.0))
            else:
                out[i, j] = static[v, j]
    return out


def _node_rows():
    """:func:`_observed_rows` compiled."""
    return _compiled(_observed_rows)


def _changed_rows(nodes: np.ndarray, features: np.ndarray, seen: np.ndarray, first: int, last: int) -> np.ndarray:
    """Compiled by numba (:func:`_stale`): the indices k of ``nodes`` whose ``features`` columns
    ``first:last`` (those that change in an episode) differ from ``seen`` (NaN: never seen), ``seen``
    updated for them."""
    out = np.empty(nodes.shape[0], np.int64)
    count = 0
    for k in range(nodes.shape[0]):
        v = nodes[k]
        same = True
        for j in range(first, last):
            same = same and features[v, j] == seen[v, j - first]
        if not same:
            for j in range(first, last):
                seen[v, j - first] = features[v, j]
            out[count] = k
            count += 1
    return out[:count]


def _stale():
    """:func:`_changed_rows` compiled."""
    return _compiled(_changed_rows)


def _neighbour_means(h: np.ndarray, edges: np.ndarray, out: np.ndarray) -> None:
    """Compiled by numba (:func:`_means_pass`): ``out`` (N, 3H) = [h, mean of each node's predecessors'
    rows of h, mean of its successors'] over the edges ``edges[e, 0] -> edges[e, 1]`` (0 without any);
    the sums in edge order, as torch's ``index_add_``."""
    n, width = h.shape
    into = np.zeros(n, np.float32)
    outof = np.zeros(n, np.float32)
    out[:, :] = 0.0
    out[:, :width] = h
    for e in range(edges.shape[0]):
        b, a = edges[e, 0], edges[e, 1]
        into[a] += 1.0
        outof[b] += 1.0
        for k in range(width):
            out[a, width + k] += h[b, k]
            out[b, 2 * width + k] += h[a, k]
    for v in range(n):
        p, s = max(into[v], np.float32(1.0)), max(outof[v], np.float32(1.0))
        for k in range(width):
            out[v, width + k] /= p
            out[v, 2 * width + k] /= s


def _means_pass():
    """:func:`_neighbour_means` compiled."""
    return _compiled(_neighbour_means)


def _pool(h: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """Compiled by numba (:func:`_pooled`): the mean of ``h``'s rows (float32, summed row after row, the
    bits of numpy's ``h.sum(0)``, checked) plus ``extra``, as ``h.sum(0) / len(h) + extra``."""
    rows, width = h.shape
    total = np.zeros(width, np.float32)
    for i in range(rows):
        for k in range(width):
            total[k] += h[i, k]
    count = np.float32(max(rows, 1))
    out = np.empty(width, np.float32)
    for k in range(width):
        out[k] = total[k] / count + extra[k]
    return out


def _pooled():
    """:func:`_pool` compiled."""
    return _compiled(_pool)


def _affine(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, relu: bool) -> np.ndarray:
    """Compiled by numba (:func:`_dense`): ``x @ weight + bias`` on a few float32 rows (``weight`` (in,
    out)), then max(0, .) where ``relu``: the small layers, where a library call costs more than its
    arithmetic."""
    rows, inputs = x.shape
    outputs = weight.shape[1]
    out = np.zeros((rows, outputs), np.float32)
    for i in range(rows):
        for j in range(inputs):
            xij = x[i, j]
            for k in range(outputs):
                out[i, k] += xij * weight[j, k]
        for k in range(outputs):
            value = out[i, k] + bias[k]
            out[i, k] = max(value, np.float32(0.0)) if relu else value
    return out


def _dense():
    """:func:`_affine` compiled."""
    return _compiled(_affine)


def _pair_scores(h, g, joint, nodes, robots, handling, travel, compatible, node_w, node_b, robot_w, scalar_w, out_w, out_b,
                 last_w, last_b) -> np.ndarray:
    """Compiled by numba (:func:`_pairs`): the logit of each (task row ``nodes[i]``, robot ``robots[i]``)
    pair, as ``DispatchExtractor.pair_logits``: max(0, node term + robot term + scalars term + ``joint``
    (the context's term)), two more layers. The scalars: symlog of the handling, the travel and their sum
    (s, float32), the compatibility. Weights (in, out), float32."""
    width = node_w.shape[1]
    logits = np.empty(nodes.shape[0], np.float32)
    pair = np.empty(width, np.float32)
    hidden = np.empty(width, np.float32)
    scalars = np.empty(4, np.float32)
    for i in range(nodes.shape[0]):
        v, r = nodes[i], robots[i]
        scalars[0], scalars[1] = handling[i], travel[i]
        scalars[2] = np.float32(handling[i] + travel[i])
        for j in range(3):
            x = scalars[j]
            scalars[j] = np.log1p(x) if x > 0 else (-np.log1p(-x) if x < 0 else np.float32(0.0))
        scalars[3] = compatible[i]
        for k in range(width):
            a = node_b[k]
            b = np.float32(0.0)
            c = np.float32(0.0)
            for j in range(h.shape[1]):
                a += h[v, j] * node_w[j, k]
                b += g[r, j] * robot_w[j, k]
            for j in range(4):
                c += scalars[j] * scalar_w[j, k]
            pair[k] = max(np.float32(a + b + c + joint[k]), np.float32(0.0))
        for k in range(width):
            a = out_b[k]
            for j in range(width):
                a += pair[j] * out_w[j, k]
            hidden[k] = max(a, np.float32(0.0))
        score = last_b[0]
        for j in range(width):
            score += hidden[j] * last_w[j, 0]
        logits[i] = score
    return logits


def _pairs():
    """:func:`_pair_scores` compiled."""
    return _compiled(_pair_scores)


def _linear(x: th.Tensor, layer: tuple, relu: bool = False) -> th.Tensor:
    """One layer on many rows (a (weight (out, in), bias) pair of tensors), as ``torch.nn.functional.linear``
    (one BLAS call, torch's one thread), max(0, .) in place where ``relu``."""
    out = th.addmm(layer[1], x, layer[0].t())
    return out.relu_() if relu else out


class LocalForward:
    """A local, unadvised :class:`~bimrobot.planning.learned.DispatchExtractor`'s scores without module calls.

    ``embed(h0, edges, robot_features, robot_mask, context)`` -> (node embeddings (N, H), robot
    embeddings (R, H), pooled context (2H,)), float32 numpy, for the observed nodes only (rows renumbered;
    ``edges`` (E, 2) before -> after between them; ``h0`` the node MLP's output for them, kept between
    decisions, see :meth:`node_embeddings`); :meth:`pair_logits` and :meth:`wait_logit` as the extractor's. The layers over
    every observed node are torch's (one BLAS call each), the rest compiled loops (numba)."""

    def __init__(self, extractor):
        if extractor.advisers or extractor.context_in is None:
            raise ValueError("LocalForward scores only a policy of the local observation without advice")
        w = {k: v.detach().clone() for k, v in extractor.state_dict().items()}
        small = lambda name: np.ascontiguousarray(w[name].numpy().T, dtype=np.float32)  # noqa: E731 - (in, out)
        bias = lambda name: np.ascontiguousarray(w[name].numpy(), dtype=np.float32)  # noqa: E731
        self.node = [(w[f"node_in.{i}.weight"], w[f"node_in.{i}.bias"]) for i in (0, 2)]
        self.passes = [(w[f"passes.{i}.0.weight"], w[f"passes.{i}.0.bias"]) for i in range(len(extractor.passes))]
        self.robot = [(small(f"robot_in.{i}.weight"), bias(f"robot_in.{i}.bias")) for i in (0, 2)]
        self.context_in = (small("context_in.weight"), bias("context_in.bias"))
        self.pair_context = small("pair_context.weight")
        self.pair = (small("pair_node.weight"), bias("pair_node.bias"), small("pair_robot.weight"), small("pair_scalars.weight"),
                     small("pair_out.1.weight"), bias("pair_out.1.bias"), small("pair_out.3.weight"), bias("pair_out.3.bias"))
        self.wait = [(small(f"wait.{i}.weight"), bias(f"wait.{i}.bias")) for i in (0, 2)]
        self.hidden = extractor.hidden
        self._static: tuple = (None, None)  # (environment and episode, symlog of its node features then)
        self._kept: tuple = (None, None)  # per graph node: the node MLP's output and the changing features it read
        self._rows = np.empty((0, self.hidden), np.float32)  # the observed nodes' embeddings, rewritten at each decision
        self._joined = np.empty((0, 3 * self.hidden), np.float32)  # the message passing's inputs, likewise
        self.edges = np.empty((0, 2), np.int64)  # the observed edges' rows (:func:`_local_inputs`' ``out``), likewise

    def inputs(self, env, views: dict) -> tuple[tuple, np.ndarray]:
        """:func:`_local_inputs` without the node features (:meth:`node_embeddings` reads them), the edges
        written into a buffer kept between decisions."""
        if len(self.edges) != len(env._local.owned[1]):
            self.edges = np.empty((len(env._local.owned[1]), 2), np.int64)
        return _local_inputs(env, views, features=False, out=self.edges)

    def node_inputs(self, env, nodes: np.ndarray) -> np.ndarray:
        """symlog of the node features of graph nodes ``nodes`` of ``env`` (a local ``DispatchEnv``) now:
        the columns that never change in an episode (all but the state and the earliest start) from a
        table computed once per episode, the others now."""
        if self._static[0] != (id(env), env._episode):
            self._static = ((id(env), env._episode), _symlog()(np.ascontiguousarray(env._nodes, dtype=np.float32)))
        return _node_rows()(self._static[1], env._nodes, nodes, *CHANGING)

    def node_embeddings(self, env, nodes: np.ndarray) -> np.ndarray:
        """The node MLP's output (N, H) for graph nodes ``nodes`` of ``env`` now. A node's output depends
        on its own features only, so it is kept between the decisions of an episode and computed again
        only where its state or earliest start changed (about 47 of 609 observed nodes per decision on
        generated:steel:1000). Computed :data:`MIN_ROWS` rows or more at a time, so each row has the bits
        of the whole batch's product (torch takes another path, with other rounding, for fewer)."""
        if len(nodes) < MIN_ROWS:  # all of them, as one batch, not kept
            return self._node_mlp(self.node_inputs(env, nodes))
        if self._kept[0] != (id(env), env._episode):
            n = len(env._nodes)
            self._kept = ((id(env), env._episode), (np.zeros((n, self.hidden), np.float32),
                                                    np.full((n, CHANGING[1] - CHANGING[0]), np.nan, np.float32)))
        h0, seen = self._kept[1]
        stale = _stale()(nodes, env._nodes, seen, *CHANGING)
        if len(stale):
            rows = nodes[np.union1d(stale, np.arange(MIN_ROWS))] if len(stale) < MIN_ROWS else nodes[stale]
            h0[rows] = self._node_mlp(self.node_inputs(env, rows))
        if len(self._rows) < len(nodes):  # kept between decisions (no new pages at each one)
            self._rows = np.empty((2 * len(nodes), self.hidden), np.float32)
        return np.take(h0, nodes, axis=0, out=self._rows[: len(nodes)])

    def _node_mlp(self, node_rows: np.ndarray) -> np.ndarray:
        """The node MLP (two layers, torch's ``addmm``) on symlog'd feature rows."""
        with th.inference_mode():
            return _linear(_linear(th.from_numpy(node_rows), self.node[0], True), self.node[1], True).numpy()

    def embed(self, h0, edges, robot_features, robot_mask, context) -> tuple:
        """The node and robot embeddings after the message passing and the pooled context (float32 numpy),
        from the node MLP's output ``h0`` (:meth:`node_embeddings`; overwritten: the embeddings are computed in
        place). ``edges`` (E, 2) int64: before -> after, rows of ``h0``."""
        dense = _dense()
        mask = np.asarray(robot_mask, np.float32)
        g = _symlog()(np.ascontiguousarray(robot_features, dtype=np.float32))
        for weight, bias in self.robot:
            g = dense(g, weight, bias, True)
        g *= mask[:, None]
        edges = np.ascontiguousarray(edges, dtype=np.int64)
        if len(self._joined) < len(h0):  # kept between decisions, as the rows
            self._joined = np.empty((2 * len(h0), 3 * self.hidden), np.float32)
        joined = self._joined[: len(h0)]
        with th.inference_mode():
            h = th.from_numpy(h0)
            for layer in self.passes:
                _means_pass()(h0, edges, joined)
                h = h.add_(_linear(th.from_numpy(joined), layer, True))
        h = h.numpy()
        pooled = _pooled()(h, dense(np.asarray(context, np.float32)[None], *self.context_in, False)[0])
        return h, g, np.concatenate([pooled, g.sum(0) / np.float32(max(float(mask.sum()), 1.0))])

    def pair_logits(self, h, g, context, nodes, robots, handling, travel, compatible) -> np.ndarray:
        """The logits (K,) of the pairs (``nodes``, ``robots``: rows of h and g, int64 arrays) with their
        handling and travel times (s) and compatibility."""
        joint = _dense()(context[None], self.pair_context, np.zeros(self.pair_context.shape[1], np.float32), False)[0]
        return _pairs()(h, g, joint, nodes, robots, np.asarray(handling, np.float32), np.asarray(travel, np.float32),
                        np.asarray(compatible, np.float32), *self.pair)

    def wait_logit(self, context) -> float:
        """The wait logit from the pooled context."""
        (first, first_b), (last, last_b) = self.wait
        return float(_dense()(_dense()(context[None], first, first_b, True), last, last_b, False)[0, 0])


def _observed_edge_rows(nodes, start, ids, edge_mask, precedence, where, out) -> int:
    """Compiled by numba (:func:`_edge_rows`): the observed edges (``edge_mask`` 1) owned by ``nodes``
    (node v's are ``ids[start[v]:start[v + 1]]``), in that order, as (before, after) rows of the observed
    nodes (``where``), written into ``out`` (at least as many rows as the edges); returns their count."""
    count = 0
    for v in nodes:
        for i in range(start[v], start[v + 1]):
            e = ids[i]
            if edge_mask[e] == 1:
                out[count, 0] = where[precedence[e, 0]]
                out[count, 1] = where[precedence[e, 1]]
                count += 1
    return count


def _edge_rows():
    """:func:`_observed_edge_rows` compiled."""
    return _compiled(_observed_edge_rows)


def _local_inputs(env, views: dict, features: bool = True, out: np.ndarray | None = None) -> tuple[tuple, np.ndarray]:
    """The embedding's inputs for the local observation, as numpy arrays: the observed nodes' features,
    the edges between them renumbered (row k is graph node ``env._local.nodes[k]``; each edge read once, at
    the node that owns it), the robots' features and mask, the context; and where each graph node's row is
    (the keeper's ``where``). Their cost grows with the observed nodes, not the building. ``out``: an
    (edges of the building, 2) int64 buffer the edges are written into (a view of it is returned)."""
    local = env._local
    nodes = local.nodes
    if out is None:
        out = np.empty((len(local.owned[1]), 2), np.int64)
    pairs = out[: _edge_rows()(nodes, *local.owned, local.edge_mask, env.precedence, local.where, out)]
    return (views["node_features"][nodes] if features else None, pairs, views["robot_features"], views["robot_mask"], views["context"]), local.where
