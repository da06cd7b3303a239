"""The numba kernels of :class:`bimrobot.assembly.vector.BatchedAssemblySim`: one pass over the
environments per call, each doing what :class:`bimrobot.assembly.env.AssemblyEnv` does for itself.

Compiled on first use and cached next to this file (``cache=True``); see "Speed" in docs/assembly.md.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# ------------------------------------------------------------------------------------------ kernels
#
# The simulator's state lives in the arrays of BatchedAssemblySim (one row per environment); the numba
# kernels below loop over environments and do for each what AssemblyEnv does for itself, in the same
# order and with the same float operations (no fastmath), so that rewards and observations are equal bit
# for bit. ``S`` is the tuple of state arrays and ``G`` the tuple of scenario tables built by
# BatchedAssemblySim._state() / _build_tables(); the kernels unpack them once per call and hand the
# small helpers only the arrays they use, inlined (with the branch-free mask below, about 20 % faster
# per step than helpers that unpack the tuples themselves).
#
# Occupancy is a grid padded by one blocked cell all round (flat index over (W+2, L+2, H+2)): a move
# shifts a valid pose by one cell, so its cells never leave the padded grid and a move is free when the
# bytes at its 4 (repeated) cell offsets are all 0, without bounds tests.

_NO_ERROR = -1


@njit(cache=True, inline="always")
def _k_clear(obs, fp, i):
    """Erase channels 2 and 4 of env i's current component (drawn at obs indices fp[i])."""
    for j in range(4):
        obs[i, fp[i, j] + 2] = 0
        obs[i, fp[i, j] + 4] = 0


@njit(cache=True, inline="always")
def _k_draw(obs, fp, pos, cur, steps, fp_offsets, top_offset, L, i, epsilon):
    """Channels 2 (top z) and 4 (past epsilon) of env i's current component at its pose; fp[i] = its cells."""
    c = cur[i]
    base = (pos[i, 0] * L + pos[i, 1]) * 7
    top = np.int8(pos[i, 2] + top_offset[c])
    late = np.int8(1 if steps[i] > epsilon else 0)
    for j in range(4):
        f = base + fp_offsets[c, j]
        fp[i, j] = f
        obs[i, f + 2] = top
        obs[i, f + 4] = late


@njit(cache=True, inline="always")
def _k_mask(occ, pflat, cur, mask, delta, offsets, i):
    """mask[i, a]: move a of env i's current component would not be blocked."""
    o0, o1, o2, o3 = offsets[cur[i], 0], offsets[cur[i], 1], offsets[cur[i], 2], offsets[cur[i], 3]
    for a in range(6):
        q = pflat[i] + delta[a]
        # no early exit: a branch per cell costs more than the 4 loads (blocked or not is unpredictable)
        mask[i, a] = (occ[i, q + o0] | occ[i, q + o1] | occ[i, q + o2] | occ[i, q + o3]) == 0


@njit(cache=True)
def _k_become_current(S, G, i, comp):
    """Pick up component ``comp`` of env i (the spec's lifted pose); False when it cannot be lifted free."""
    occ, pos, pflat, cur, steps, starts, wait_cells = S[0], S[1], S[2], S[3], S[4], S[8], S[9]
    dims, stride = G[0], G[1]
    comp_len, comp_axis, comp_is_column, comp_target_z, ext, offsets = G[4], G[5], G[6], G[7], G[8], G[9]
    W, L, H = dims[0], dims[1], dims[2]
    for j in range(4):
        occ[i, wait_cells[i, comp, j]] = 0
    n1 = starts[i, comp, 0]
    n2 = starts[i, comp, 1]
    lo0, lo1, lo2 = min(n1[0], n2[0]), min(n1[1], n2[1]), min(n1[2], n2[2])
    if comp_is_column[comp]:  # stands up on node1 (x, y), its bottom one cell above where it lay
        cx, cy, cz = n1[0], n1[1], lo2 + 1
    else:  # rises to its slot's height and turns about its centre cell onto its slot's axis
        s0, s1, s2 = abs(n1[0] - n2[0]), abs(n1[1] - n2[1]), abs(n1[2] - n2[2])
        n = max(s0, s1, s2)
        # the centre cell of the lying run (along its first longest axis)
        cx = lo0 + (n // 2 if s0 == n else 0)
        cy = lo1 + (n // 2 if s1 == n and s0 != n else 0)
        cz = comp_target_z[comp]
        half = (comp_len[comp] - 1) // 2
        if comp_axis[comp] == 0:
            cx -= half
        elif comp_axis[comp] == 1:
            cy -= half
        else:
            cz -= half
    cx = min(max(cx, 0), W - ext[comp, 0])
    cy = min(max(cy, 0), L - ext[comp, 1])
    lifted = -1
    for z in range(cz, H - ext[comp, 2] + 1):
        p = (cx + 1) * stride[0] + (cy + 1) * stride[1] + z + 1
        free = True
        for j in range(4):
            if occ[i, p + offsets[comp, j]] != 0:
                free = False
                break
        if free:
            lifted = z
            pflat[i] = p
            break
    if lifted < 0:
        return False
    pos[i, 0], pos[i, 1], pos[i, 2] = cx, cy, lifted
    cur[i] = comp
    steps[i] = 0
    return True


@njit(cache=True)
def _k_refresh_static(S, G, i):
    """Channels 0, 1, 3 and 5 of env i (after a reset or a placement); 2, 4 and 6 are left alone."""
    cur, k, filled, wait_xy, wait_z, obs = S[3], S[6], S[7], S[10], S[11], S[12]
    dims, target_xy, target_z = G[0], G[15], G[16]
    WL, n_comp, n_target = dims[0] * dims[1], dims[3], dims[4]
    for xy in range(WL):
        b = xy * 7
        obs[i, b] = 0
        obs[i, b + 1] = 0
        obs[i, b + 3] = 0
        obs[i, b + 5] = 0
    standing = np.int8(k[i])
    for t in range(n_target):
        if filled[i, t]:
            for j in range(4):
                obs[i, target_xy[t, j] * 7 + 5] = standing
        else:
            for j in range(4):
                b = target_xy[t, j] * 7
                obs[i, b] = 1
                z = np.int8(target_z[t, j])
                if z > obs[i, b + 3]:
                    obs[i, b + 3] = z
    for c in range(cur[i] + 1, n_comp):
        for j in range(4):
            b = wait_xy[i, c, j] * 7 + 1
            z = np.int8(wait_z[i, c, j])
            if z > obs[i, b]:
                obs[i, b] = z


@njit(cache=True)
def _k_step(S, G, actions, r0, epsilon, bonus, time_limit, reward, terminated, truncated, blocked, placed):
    """One step of every environment (ended ones stay done: the caller resets them). Returns the first
    component that could not be lifted free, or _NO_ERROR."""
    occ, pos, pflat, cur, steps, elapsed, k, filled, starts, wait_cells, wait_xy, wait_z, obs, mask, fp, done = S
    dims, delta, moves = G[0], G[2], G[3]
    offsets, fp_offsets, top_offset, arrival, supports, target_cells = G[9], G[10], G[11], G[12], G[13], G[14]
    L, n_comp = dims[1], dims[3]
    error = _NO_ERROR
    for i in range(actions.shape[0]):
        if done[i]:
            reward[i] = 0.0
            terminated[i] = False
            truncated[i] = False
            blocked[i] = False
            placed[i] = False
            continue
        a = actions[i]
        _k_clear(obs, fp, i)
        moving = mask[i, a]
        if moving:
            pos[i, 0] += moves[a, 0]
            pos[i, 1] += moves[a, 1]
            pos[i, 2] += moves[a, 2]
            pflat[i] += delta[a]
        steps[i] += 1
        elapsed[i] += 1
        c = cur[i]
        arrive = False
        if moving:
            t = arrival[c, pflat[i]]
            arrive = t >= 0 and not filled[i, t] and filled[i, supports[t, 0]] and filled[i, supports[t, 1]]
        if arrive:
            reward[i] = float(k[i] + 1) + (bonus if c == n_comp - 1 else 0.0)
            # placed: target t is filled for good and the next component is picked up
            for j in range(4):
                occ[i, target_cells[t, j]] = 1
            filled[i, t] = True
            k[i] += 1
            if c + 1 >= n_comp:
                cur[i] = c + 1
                done[i] = True
            elif not _k_become_current(S, G, i, c + 1) and error == _NO_ERROR:
                error = c + 1
            _k_refresh_static(S, G, i)
        else:
            reward[i] = r0 / (c + 1) * (2.0 if steps[i] > epsilon else 1.0)
        blocked[i] = not moving
        placed[i] = arrive
        terminated[i] = done[i]
        truncated[i] = elapsed[i] >= time_limit
        if not done[i]:
            _k_draw(obs, fp, pos, cur, steps, fp_offsets, top_offset, L, i, epsilon)
            _k_mask(occ, pflat, cur, mask, delta, offsets, i)
        if terminated[i] or truncated[i]:
            done[i] = True
            for b in range(6):
                mask[i, b] = False
    return error


@njit(cache=True)
def _k_reset(S, G, envs, layouts, prebuilt, epsilon):
    """Start a new episode in each env ``envs[r]`` from lying poses ``layouts[r]`` (C, 2, 3) and prebuilt
    slots ``prebuilt[r]`` (a single row of either serves every env), their occupancy rows already set to
    the static cells and their observation rows to the blank one. Returns the first component that could
    not be lifted free, or _NO_ERROR."""
    occ, pos, pflat, cur, steps, elapsed, k, filled, starts, wait_cells, wait_xy, wait_z, obs, mask, fp, done = S
    dims, stride, delta, offsets, fp_offsets, top_offset = G[0], G[1], G[2], G[9], G[10], G[11]
    target_cells = G[14]
    L, n_comp, n_target = dims[1], dims[3], dims[4]
    error = _NO_ERROR
    for r in range(envs.shape[0]):
        i = envs[r]
        lay = layouts[min(r, layouts.shape[0] - 1)]
        pre = prebuilt[min(r, prebuilt.shape[0] - 1)]
        starts[i] = lay  # occ[i] and obs[i] (static cells, obstacle channel) are set by the caller
        filled[i] = False
        filled[i, n_target] = True  # the "always filled" support of targets that need none
        for s in pre:
            filled[i, s] = True
            for j in range(4):
                occ[i, target_cells[s, j]] = 1
        for c in range(n_comp):  # waiting cells: the lying run from its low corner
            lo0 = min(lay[c, 0, 0], lay[c, 1, 0])
            lo1 = min(lay[c, 0, 1], lay[c, 1, 1])
            lo2 = min(lay[c, 0, 2], lay[c, 1, 2])
            s0 = abs(lay[c, 0, 0] - lay[c, 1, 0])
            s1 = abs(lay[c, 0, 1] - lay[c, 1, 1])
            s2 = abs(lay[c, 0, 2] - lay[c, 1, 2])
            n = max(s0, s1, s2)
            axis = 0 if s0 == n else (1 if s1 == n else 2)
            for j in range(4):
                kk = min(j, n)
                x = lo0 + (kk if axis == 0 else 0)
                y = lo1 + (kk if axis == 1 else 0)
                z = lo2 + (kk if axis == 2 else 0)
                f = (x + 1) * stride[0] + (y + 1) * stride[1] + z + 1
                wait_cells[i, c, j] = f
                wait_xy[i, c, j] = x * L + y
                wait_z[i, c, j] = z
                occ[i, f] = 1
        k[i] = len(pre)
        elapsed[i] = 0
        done[i] = False
        if not _k_become_current(S, G, i, 0) and error == _NO_ERROR:
            error = 0
        _k_refresh_static(S, G, i)
        _k_draw(obs, fp, pos, cur, steps, fp_offsets, top_offset, L, i, epsilon)
        _k_mask(occ, pflat, cur, mask, delta, offsets, i)
    return error


@njit(cache=True)
def _k_layouts(
    block, rows, status, progress, occupied, out, comp_len, yard_x, yard_y, lying, candidates, n_candidates, L
):
    """scenario.sample_layout for the envs ``rows[j]`` of a reset, going on from ``progress[rows[j]]``
    (component, failed draws) and ``occupied[rows[j]]`` with the next block of 192 uniforms ``block[j]``.
    status[j]: 0 done (the layout is in out[rows[j]]), 1 the block is used up (call again with the next
    block), 2 a component fits nowhere: the attempt is cleared (call again with a fresh block)."""
    WL = occupied.shape[1]
    n_comp = comp_len.shape[0]
    n_x = yard_x.shape[0]
    for j in range(rows.shape[0]):
        r = rows[j]
        ci, failures = progress[r, 0], progress[r, 1]
        used = 0
        status[j] = 0
        while ci < n_comp and status[j] == 0:
            if used == 192:
                status[j] = 1
                break
            n = comp_len[ci]
            axis_u, x_u, y_u = block[j, used], block[j, used + 1], block[j, used + 2]
            used += 3
            xi = int(x_u * n_x)
            index = (WL if axis_u >= 0.5 else 0) + yard_x[xi] * L + yard_y[xi, 0] + int(y_u * yard_y[xi, 1])
            if lying[ci, index, 0] >= 0:
                free = True
                for m in range(n):
                    if occupied[r, lying[ci, index, m]]:
                        free = False
                        break
                if free:
                    for m in range(n):
                        occupied[r, lying[ci, index, m]] = 1
                    first, last = lying[ci, index, 0], lying[ci, index, n - 1]
                    out[r, ci, 0, 0], out[r, ci, 0, 1], out[r, ci, 0, 2] = first // L, first % L, 1
                    out[r, ci, 1, 0], out[r, ci, 1, 1], out[r, ci, 1, 2] = last // L, last % L, 1
                    ci += 1
                    failures = 0
                    continue
            failures += 1
            if failures % 32 == 0:  # the exact check: does it fit anywhere at all?
                fits = False
                for q in range(n_candidates[ci]):
                    clear = True
                    for m in range(n):
                        if occupied[r, candidates[ci, q, m]]:
                            clear = False
                            break
                    if clear:
                        fits = True
                        break
                if not fits:
                    status[j] = 2
                    ci, failures = 0, 0
                    occupied[r] = 0
        progress[r, 0], progress[r, 1] = ci, failures

