"""Chain surgery for the corridor (:mod:`foam_mj.planners.corridor`): certified chords, their thinning, splicing
them and pressing bubbles into a chain, pruning and re-covering a chain along a path, and deepening its hatches.

A chain is a sequence of balls (centres C, certified radii R) in which consecutive balls overlap with a hatch;
a polyline P "lies in" the chain when its segment j lies in ball j. Every new ball's radius comes from the
oracle (certified), and every operation here keeps a polyline that the new chain holds, no longer than the old
one, so the shortest path through the new chain is no longer either.
"""

from __future__ import annotations

import numpy as np

from foam_mj.paths import row_norms

#: A hatch must be at least this fraction of the smaller radius deep.
HATCH = 0.05
#: The final rosary's hatches are at least this fraction of the smaller radius deep (hatch sampling by
#: rejection from the smaller ball then accepts a few per cent of draws even in 6-D).
DEEP = 0.5
#: Outward pushes of a refinement bubble's centre, in units of the radius at the pressing waypoint.
PUSH = np.array([0.0, 0.5, 0.75, 0.9])
#: Ball inset of the cone program (configuration units), as the convex smoother's default.
INSET = 1e-6
#: certify_chords queries every COARSE-th point of the chords first (a chord through an obstacle dies there).
COARSE = 4
#: A gap between two chord points that do not overlap deeply gets ceil(d / (SPLIT x the smaller radius)) - 1
#: evenly spaced points at once (at most GAP_POINTS): fewer bisection levels (one batch of queries each).
SPLIT = 1.4
GAP_POINTS = 8


def arc_points(P: np.ndarray, x: np.ndarray, metric: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points of the polyline P at arc lengths x (weighted by ``metric``), and the segment index of each."""
    seg = row_norms(np.diff(P, axis=0) * (1.0 if metric is None else metric))
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    j = np.minimum(np.maximum(np.searchsorted(cum, x, side="right") - 1, 0), len(seg) - 1)
    f = np.clip((x - cum[j]) / np.where(seg[j] > 0, seg[j], 1.0), 0.0, 1.0)
    return P[j] + f[:, None] * (P[j + 1] - P[j]), j


def certify_chords(oracle, A: np.ndarray, B: np.ndarray, floor: float, spacing: float, levels: int = 10,
                   near: tuple[np.ndarray, np.ndarray] | None = None) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """For each straight chord A[k] -> B[k]: bubble centres along it, every two consecutive overlapping
    with a hatch and every radius >= floor (a certified chain that holds the chord), or None.

    Centres start ``spacing`` apart (every COARSE-th point queried first); a gap between two neighbours that do
    not overlap deeply gets evenly spaced points (see SPLIT, GAP_POINTS), all chords' new points in one batch
    per level (at most ``levels``). The chords' points live in flat
    arrays sorted by (chord, position): no Python loop over chords.

    ``near`` = (centres, radii): bubbles whose radii are the certified radii at their centres (the chain the chords
    shortcut). A coarse point x then has radius at most min_j r_j + |x - c_j| (r is 1-Lipschitz), and MuJoCo
    measures each pair only that far (:meth:`foam_mj.bubbles.BubbleOracle.radii_below`: the same radii to the
    last bit); without it the coarse points get full queries. On MuJoCo Menagerie's xArm7 and Panda (96 and
    190 mesh pairs) a full query costs 160-190 us, a capped one 50-65."""
    lo, hi = oracle.robot.lower, oracle.robot.upper
    K = len(A)
    if K == 0:
        return []
    V = B - A
    m = np.maximum(1, np.ceil(row_norms(V) / spacing).astype(np.int64))
    cid = np.repeat(np.arange(K), m + 1)
    start = np.repeat(np.cumsum(m + 1) - (m + 1), m + 1)
    t = (np.arange(len(cid)) - start) / m[cid]
    pts = A[cid] + V[cid] * t[:, None]
    alive = np.ones(K, dtype=bool)
    r = np.zeros(len(pts))
    # A chord through an obstacle dies on any point: every COARSE-th point first, the others of the survivors after.
    coarse = (np.arange(len(cid)) - start) % COARSE == COARSE // 2 if COARSE > 1 else np.ones(len(cid), dtype=bool)
    if near is None:
        r[coarse] = oracle.radii(pts[coarse])
    else:
        X = pts[coarse]
        NC, NR = near
        # |x - c_j| for every coarse point and bubble from one product (its rounding, ~1e-7 at worst, is far
        # below radii_below's slack; and a cap never makes a radius larger: the certificate does not rest on it).
        sq = np.einsum("ij,ij->i", X, X)[:, None] + np.einsum("ij,ij->i", NC, NC)[None, :] - 2.0 * (X @ NC.T)
        upper = (np.sqrt(np.maximum(sq, 0.0)) + NR[None, :]).min(axis=1)
        r[coarse] = oracle.radii_below(X, upper)
    alive[cid[coarse & (r < floor)]] = False
    rest = ~coarse & alive[cid]
    if rest.any():
        # r is 1-Lipschitz: a point's radius is at most a sized neighbour's (the nearest coarse points of its
        # chord, before and after it) plus their distance, and MuJoCo measures each pair only that far.
        at = np.arange(len(cid))
        before = np.maximum.accumulate(np.where(coarse, at, -1))
        after = np.minimum.accumulate(np.where(coarse, at, len(cid))[::-1])[::-1]
        upper = np.full(len(cid), np.inf)
        for nearest in (before, after):
            ok = (nearest >= 0) & (nearest < len(cid))
            ok[ok] = cid[nearest[ok]] == cid[ok]
            upper[ok] = np.minimum(upper[ok], r[nearest[ok]] + row_norms(pts[ok] - pts[nearest[ok]]))
        r[rest] = oracle.radii_below(pts[rest], upper[rest])
        alive[cid[rest & (r < floor)]] = False

    def gaps() -> tuple[np.ndarray, np.ndarray]:
        """Whether each two consecutive points (of one chord) do not overlap deeply, and their distances."""
        d = row_norms(pts[1:] - pts[:-1])
        return (cid[:-1] == cid[1:]) & (d > r[:-1] + r[1:] - DEEP * np.minimum(r[:-1], r[1:])), d

    for _ in range(levels):
        keep = alive[cid]
        if not keep.all():  # drop the dead chords' points (all points left are alive)
            cid, t, pts, r = cid[keep], t[keep], pts[keep], r[keep]
        gap, d = gaps()
        g = np.flatnonzero(gap)
        if g.size == 0:
            break
        # Each gap gets evenly spaced points, as many as its ends' smaller radius suggests (SPLIT x that radius
        # apart: deep overlaps if the radius holds in between), at most GAP_POINTS; one if GAP_POINTS is 1.
        dg = d[g]
        cnt = np.minimum(np.maximum(np.ceil(dg / (SPLIT * np.maximum(np.minimum(r[g], r[g + 1]), 1e-12))).astype(np.int64) - 1, 1), GAP_POINTS)
        gi = np.repeat(g, cnt)
        frac = (np.arange(len(gi)) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1) / np.repeat(cnt + 1, cnt)
        cm = cid[gi]
        tm = t[gi] + frac * (t[gi + 1] - t[gi])
        newp = A[cm] + V[cm] * tm[:, None]
        inb = np.all((newp >= lo) & (newp <= hi), axis=1)
        # At most either end's radius plus the distance to it (r is 1-Lipschitz).
        upper = np.minimum(r[gi] + row_norms(newp - pts[gi]), r[gi + 1] + row_norms(newp - pts[gi + 1]))
        if inb.all():
            rn = oracle.radii_below(newp, upper)
        else:
            rn = np.zeros(len(newp))
            if inb.any():
                rn[inb] = oracle.radii_below(newp[inb], upper[inb])
        alive[cm[rn < floor]] = False
        cid, t = np.concatenate([cid, cm]), np.concatenate([t, tm])
        pts, r = np.concatenate([pts, newp]), np.concatenate([r, rn])
        order = np.lexsort((t, cid))
        cid, t, pts, r = cid[order], t[order], pts[order], r[order]
    else:
        alive[cid[np.flatnonzero(gaps()[0] & alive[cid[:-1]])]] = False  # still a gap after the last level
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * K
    ks = np.flatnonzero(alive)  # cid is sorted: each chord's points are one run
    for k, a, b in zip(ks.tolist(), np.searchsorted(cid, ks).tolist(), np.searchsorted(cid, ks, side="right").tolist()):
        out[k] = (pts[a:b], r[a:b])
    return out


def thin_line_chain(pts: np.ndarray, r: np.ndarray, most: int | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The fewest of a chord's bubbles (centres in order along the chord) that still hold it: from each kept
    bubble, the farthest later one that overlaps it with a deep hatch (DEEP). Two balls centred on a
    segment that overlap cover the segment between their centres, so the kept chain holds the chord.
    ``most``: None instead if that keeps more than ``most`` bubbles (the walk stops there: a chord whose chain
    is too long to be spliced, a third of the chords certified on obstacle, walked up to 38 bubbles)."""
    m = len(r)
    if m <= 2:
        return (pts, r) if most is None or m <= most else None
    # The centres lie on one line: distances are those of their positions along it (no (m, m, n) array).
    u = pts[-1] - pts[0]
    s = (pts - pts[0]) @ (u / max(float(np.linalg.norm(u)), 1e-300))
    d = np.abs(s[:, None] - s[None, :])
    ok = d <= r[:, None] + r[None, :] - DEEP * np.minimum(r[:, None], r[None, :])
    # Consecutive bubbles overlap deeply by construction (certify_chords bisects until they do).
    far = m - 1 - np.argmax(ok[:, ::-1], axis=1)  # the last bubble each one overlaps deeply
    if (far[:-1] <= np.arange(1, m)).all():
        # none overlaps a later one than the next deeply: all kept (most chords: 97 % of their bubbles)
        return (pts, r) if most is None or m <= most else None
    far = far.tolist()
    keep = [0]
    cap = m if most is None else most
    while keep[-1] < m - 1:
        if len(keep) >= cap:
            return None
        keep.append(max(far[keep[-1]], keep[-1] + 1))
    return pts[keep], r[keep]


def path_samples(P: np.ndarray, pieces: int) -> np.ndarray:
    """The polyline P sampled ``pieces`` times per segment: sample j * pieces is P[j]; the last is P[-1]."""
    t = np.arange(pieces) / pieces
    return np.concatenate([(P[:-1, None, :] + (P[1:] - P[:-1])[:, None, :] * t[None, :, None]).reshape(-1, P.shape[1]), P[-1:]])


#: Samples per segment of a path in prune_chain (and of the re-cover's bubbles' centres, which index them).
PIECES = 8
#: prune_chain looks for a bubble's held samples at most this many samples beyond its home interval.
PRUNE_BAND = 24
#: prune_chain looks at the first PRUNE_FIRST samples of the band for every bubble, further only where all are held.
PRUNE_FIRST = 8
#: prune_chain compares all pairs of bubbles up to this many bubbles, else only pairs of touching intervals.
DENSE_SUCC = 128


def prune_chain(
    C: np.ndarray, R: np.ndarray, P: np.ndarray, pieces: int = PIECES, extra: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """Positions (into the chain, then into ``extra``) of a short chain of bubbles that still holds the polyline P.

    P's segment j lies in bubble j. ``extra`` = (sample indices, certified radii): further bubbles centred at
    samples of P (:func:`path_samples` with ``pieces``) that may be used. Each bubble holds an interval of samples
    around its home (segment j's samples j*pieces .. (j+1)*pieces for chain bubble j, its centre's sample for an
    extra one; looked for at most PRUNE_BAND samples beyond). Greedily, from the bubble that holds the first
    sample, take the bubble whose interval starts inside the current one and reaches farthest, among those that
    overlap the current one with a deep hatch (DEEP; else any hatch, HATCH). The polyline through one shared
    sample per hand-over keeps each piece inside one bubble (balls are convex) and is no longer than P (triangle
    inequality), so the shortest path through the new chain is no longer either. "Holds" is tested with the
    balls shrunk by 1.5 INSET so that the cone program stays feasible."""
    k = len(R)
    D = path_samples(P, pieces)
    T = len(D)
    h0 = np.arange(k) * pieces
    h1 = h0 + pieces
    if extra is not None and len(extra[1]):
        idx = np.asarray(extra[0], dtype=np.int64)
        C, R = np.concatenate([C, D[idx]]), np.concatenate([R, extra[1]])
        h0, h1 = np.concatenate([h0, idx]), np.concatenate([h1, idx])
    nb = len(R)
    rs2 = np.maximum(R - 1.5 * INSET, 0.0) ** 2
    # Held samples after the home interval (offsets 1..PRUNE_BAND) and before it; the home interval itself is
    # held (the segment and both waypoints were solved inside the shrunk balls, to the solver's tolerance).

    def runs(rows: np.ndarray | slice, off: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For the bubbles ``rows``: how many of the samples at offsets ``off`` after the home interval, and
        before it, are held in a run next to it (all of them if the run never breaks)."""
        after = h1[rows, None] + off
        before = h0[rows, None] - off
        w = len(off)
        # Both bands in one gather (np.take: a third of the time of fancy indexing), the centres subtracted on
        # rows of 2 w n values (not a broadcast over n-long rows: a sixth of its time).
        X = np.take(D, np.concatenate([np.minimum(after, T - 1), np.maximum(before, 0)], axis=1), axis=0)
        Xr = X.reshape(len(after), -1)
        Xr -= np.tile(C[rows], 2 * w)
        held = np.einsum("ijk,ijk->ij", X, X) <= rs2[rows, None]
        ina = (after < T) & held[:, :w]
        inb = (before >= 0) & held[:, w:]
        return np.where(ina.all(axis=1), w, np.argmin(ina, axis=1)), np.where(inb.all(axis=1), w, np.argmin(inb, axis=1))

    # The first PRUNE_FIRST offsets for every bubble, the rest of the band only for those whose run reaches
    # that far (about a tenth on obstacle): the same squared distances, a third of the work.
    na, nbf = runs(slice(None), np.arange(1, PRUNE_FIRST + 1))
    more = np.flatnonzero((na == PRUNE_FIRST) | (nbf == PRUNE_FIRST))
    if len(more) and PRUNE_BAND > PRUNE_FIRST:
        ma, mb = runs(more, np.arange(PRUNE_FIRST + 1, PRUNE_BAND + 1))
        na[more] += np.where(na[more] == PRUNE_FIRST, ma, 0)
        nbf[more] += np.where(nbf[more] == PRUNE_FIRST, mb, 0)
    e = np.minimum(h1 + na, T - 1)
    s_ = np.maximum(h0 - nbf, 0)
    # The successor of each bubble (it depends on that bubble only): among the bubbles whose interval starts
    # inside its own and reaches farther, the farthest-reaching one (the first such index) with a deep hatch,
    # else with any hatch. Such a bubble holds the sample after the interval's end; for many bubbles the
    # candidates are read from the samples' lists of the bubbles that hold them (pairs of intervals that
    # touch, not all pairs).
    succ = np.full(nb, -1)
    if nb <= DENSE_SUCC:
        sq = np.einsum("ij,ij->i", C, C)
        slack = R[:, None] + R[None, :] - np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2.0 * (C @ C.T), 0.0))
        small = np.minimum(R[:, None], R[None, :])
        reach = (s_[None, :] <= e[:, None]) & (e[None, :] > e[:, None])
        for depth in (HATCH, DEEP):  # the deep tier last: it overrides where it has a candidate
            score = np.where(reach & (slack >= depth * small), e[None, :], -1)
            best = np.argmax(score, axis=1)
            succ = np.where(score[np.arange(nb), best] >= 0, best, succ)
    else:
        L = e - s_ + 1
        jj = np.repeat(np.arange(nb), L)
        pp = np.repeat(s_, L) + (np.arange(int(L.sum())) - np.repeat(np.cumsum(L) - L, L))
        order = np.argsort(pp, kind="stable")
        jj, pp = jj[order], pp[order]
        lo_ = np.searchsorted(pp, e + 1, side="left")
        cnt = np.searchsorted(pp, e + 1, side="right") - lo_
        ii = np.repeat(np.arange(nb), cnt)
        cj = jj[np.repeat(lo_, cnt) + (np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt))]
        ok = s_[cj] <= e[ii]
        ii, cj = ii[ok], cj[ok]
        slack = R[ii] + R[cj] - row_norms(np.take(C, ii, axis=0) - np.take(C, cj, axis=0))
        small = np.minimum(R[ii], R[cj])
        for depth in (HATCH, DEEP):
            sel = slack >= depth * small
            a_, b_ = ii[sel], cj[sel]  # a_ ascending
            if len(a_):
                # Per bubble the candidate of farthest reach, then smallest index: the largest key.
                key = e[b_] * nb + (nb - 1 - b_)
                first = np.flatnonzero(np.concatenate([[True], a_[1:] != a_[:-1]]))
                succ[a_[first]] = nb - 1 - np.maximum.reduceat(key, first) % nb
    start = np.flatnonzero(s_ == 0)
    out = [int(start[np.argmax(e[start])])]
    reach, succs = e.tolist(), succ.tolist()  # the walk on Python ints
    while reach[out[-1]] < T - 1:
        nxt = succs[out[-1]]
        if nxt < 0:
            return np.arange(k)  # no overlapping bubble makes progress: keep the chain as it is
        out.append(nxt)
    return np.array(out, dtype=np.int64)


def deepen(oracle, C: np.ndarray, R: np.ndarray, ids: np.ndarray, new_ids) -> tuple:
    """Make every hatch deep: where consecutive bubbles a, b overlap by less than DEEP x the smaller radius
    (a thin lens, which the smoothers' rejection sampling of hatches cannot fill), splice a certified
    bubble centred at their portal centre m. m lies in both balls, so r(m) > 0 (r is 1-Lipschitz), and
    each new hatch is more than r(m) deep: |c_a - m| < r_a gives r_a + r(m) - |c_a - m| > r(m) >= min(r_a, r(m)).
    Returns the new chain and the added bubbles."""
    d = row_norms(np.diff(C, axis=0))
    thin = np.flatnonzero(d > R[:-1] + R[1:] - DEEP * np.minimum(R[:-1], R[1:]))
    n = C.shape[1]
    if thin.size == 0:
        return C, R, ids, np.empty((0, n)), np.empty(0)
    ca, cb, ra, rb, dd = C[thin], C[thin + 1], R[thin], R[thin + 1], d[thin]
    t = (dd**2 + ra**2 - rb**2) / (2 * dd)
    m = ca + (t / dd)[:, None] * (cb - ca)
    rm = oracle.radii_below(m, np.minimum(ra + row_norms(m - ca), rb + row_norms(m - cb)))  # (1-Lipschitz)
    good = rm > 2 * INSET
    thin, m, rm = thin[good], m[good], rm[good]
    nid = new_ids(len(rm))
    return np.insert(C, thin + 1, m, axis=0), np.insert(R, thin + 1, rm), np.insert(ids, thin + 1, nid), m, rm


def held(C: np.ndarray, R: np.ndarray, w: np.ndarray) -> bool:
    """Whether every waypoint w_i lies in both its balls, b_i and b_(i+1) (the hatch it was solved in).

    The refinement relies on it (a pressing bubble centred at w_i overlaps b_i and b_(i+1) because it holds w_i;
    the prune takes segment j of the path to lie in bubble j), so a round whose cone program stopped short
    (Clarabel's InsufficientProgress or its iteration cap) with a waypoint outside is not taken. The certificate
    never depends on it: the smoothers keep their waypoints in the hatches themselves. Measured on obstacle5, arm6 and
    arm7 (seeds 0-3): 2-6 programs a plan end InsufficientProgress or AlmostSolved, all with every waypoint at least
    0.84 INSET inside its balls, so such rounds are taken as before (the same plans)."""
    if len(w) == 0:
        return True
    a = np.einsum("ij,ij->i", w - C[:-1], w - C[:-1]) <= R[:-1] ** 2
    b = np.einsum("ij,ij->i", w - C[1:], w - C[1:]) <= R[1:] ** 2
    return bool(a.all() and b.all())


def press_bubbles(oracle, C, R, w, floor):
    """Certified bubbles for the waypoints that press on a ball's boundary, pushed outward (see PUSH):
    (positions in the chain after which each goes, centres, radii)."""
    da = row_norms(w - C[:-1])
    db = row_norms(w - C[1:])
    tol = 1e-3 * np.minimum(R[:-1], R[1:]) + 4 * INSET
    on_a, on_b = da >= R[:-1] - tol, db >= R[1:] - tol
    press = np.flatnonzero(on_a | on_b)
    if press.size == 0:
        return press, np.empty((0, w.shape[1])), np.empty(0)
    wp = w[press]
    rp = oracle.radii_below(wp, np.minimum(R[:-1][press] + da[press], R[1:][press] + db[press]))  # (1-Lipschitz)
    # Outward: away from the centres of the pressed balls. r is 1-Lipschitz (the Cauchy-Schwarz ball of
    # Nascimento and Alsina 2021 Eq. 4), so a centre pushed by t r with t <= 1/2 still holds w.
    nrm = (wp - C[press]) * on_a[press, None] + (wp - C[press + 1]) * on_b[press, None]
    nrm /= np.maximum(row_norms(nrm), 1e-300)[:, None]
    cands = wp[:, None, :] + (PUSH[None, :, None] * rp[:, None, None]) * nrm[:, None, :]
    flat = cands.reshape(-1, wp.shape[1])
    okb = np.all((flat >= oracle.robot.lower) & (flat <= oracle.robot.upper), axis=1)
    rc: np.ndarray = np.zeros(len(flat))
    if okb.any():  # each PUSH x rp from w: a radius at most (1 + PUSH) x rp
        rc[okb] = oracle.radii_below(flat[okb], ((1.0 + PUSH)[None, :] * rp[:, None]).reshape(-1)[okb])
    rc = rc.reshape(len(press), len(PUSH))
    holds = rc * (1 - HATCH) > PUSH[None, :] * rp[:, None] + 2 * INSET  # holds w with a hatch of HATCH r
    reach = np.where(holds, PUSH[None, :] * rp[:, None] + rc, -np.inf)
    best = np.argmax(reach, axis=1)
    row = np.arange(len(press))
    has = np.isfinite(reach[row, best])
    pc = np.where(has[:, None], cands[row, best], wp)
    pr = np.where(has, rc[row, best], rp)
    useful = (
        (pr >= floor)
        & (row_norms(pc - C[press]) + pr > R[press] * (1 + 1e-6))
        & (row_norms(pc - C[press + 1]) + pr > R[press + 1] * (1 + 1e-6))
    )
    return press[useful], pc[useful], pr[useful]


def splice_chain(C: np.ndarray, R: np.ndarray, ids: np.ndarray, P: np.ndarray, splices: dict, press: dict, first_id: int) -> tuple:
    """The chain with chords and pressing bubbles spliced in, a polyline whose segment j lies in its bubble j,
    and the new bubbles (centres, radii).

    ``P``: a polyline whose segment j lies in bubble j of (C, R). ``splices``: {ja: (jb, centres, radii)}, a
    chord's chain from A (on segment ja) to B (on segment jb), centres on the chord in order, consecutive ones
    overlapping; it replaces bubbles ja + 1 .. jb - 1. ``press``: {p: (centre, radius)}, a bubble that holds
    P[p + 1], spliced between bubbles p and p + 1. The new polyline is P up to A, then through one point of
    each pair of consecutive chord bubbles (on the chord, in both: the middle of where both balls meet the
    chord) to B, then P on; a pressing bubble gets a segment of no length at P[p + 1]. It is no longer than P
    (the chord replaces the stretch A .. B of P). The new bubbles get the ids first_id, first_id + 1, ... in
    the order returned."""
    k = len(R)
    removed = np.zeros(k + 1, dtype=int)
    for a_, (b_, _, _) in splices.items():
        removed[a_ + 1] += 1
        removed[b_] -= 1
    inside_span = np.cumsum(removed)[:k] > 0  # bubbles a_+1 .. b_-1 of a chord
    parts_c: list[np.ndarray] = []
    parts_r: list[np.ndarray] = []
    parts_i: list[np.ndarray] = []
    verts: list[np.ndarray] = [P[:1]]
    new_c: list[np.ndarray] = []
    new_r: list[np.ndarray] = []
    for j in range(k):
        if inside_span[j]:
            continue
        parts_c.append(C[j : j + 1])
        parts_r.append(R[j : j + 1])
        parts_i.append(ids[j : j + 1])
        extra = splices[j][1:] if j in splices else (press[j][0][None, :], np.array([press[j][1]])) if j in press else None
        if j in splices:
            pc_, pr_ = splices[j][1:]
            a0 = pc_[0]
            dv = pc_[-1] - a0
            uv = dv / max(float(np.linalg.norm(dv)), 1e-300)
            sc = (pc_ - a0) @ uv
            lo_ = np.maximum(sc[1:] - pr_[1:], sc[:-1])
            hi_ = np.minimum(sc[:-1] + pr_[:-1], sc[1:])
            verts += [pc_[:1], a0 + (0.5 * (lo_ + hi_))[:, None] * uv, pc_[-1:]]
        elif j in press:
            verts += [P[j + 1 : j + 2], P[j + 1 : j + 2]]
        else:
            verts.append(P[j + 1 : j + 2])
        if extra is not None:
            parts_c.append(extra[0])
            parts_r.append(extra[1])
            parts_i.append(first_id + sum(len(x) for x in new_r) + np.arange(len(extra[1])))
            new_c.append(extra[0])
            new_r.append(extra[1])
    return np.concatenate(parts_c), np.concatenate(parts_r), np.concatenate(parts_i), np.concatenate(verts), new_c, new_r
