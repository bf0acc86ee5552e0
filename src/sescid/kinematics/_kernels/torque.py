"""The joint torques' normal equations in the fused pass: one chain (the CoP's rows x, y) feeds the
CoP's product and the torque rows' blocks (``torque_plan``), Φ never written to memory.

The torque accumulator is augmented like the CoP's: its columns are the moving bodies' reduced
columns in depth-first order, the measured joints' offsets (and friction bands), then the
targets; each pair of columns is summed once, in a fixed order (``gram``'s 8-lane FMA tiles),
and ``fold_torque`` turns it into the symmetric sums in ``Reduction`` order.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.fused import (
    angles_ok,
    block_angles,
    body_columns,
    chain_buffers,
    cop_rows,
    cop_target,
)
from sescid.kinematics._kernels.gram import sum_tile, sum_tile3, syrk
from sescid.kinematics._kernels.intrinsics import (
    vadd,
    vfma,
    vload,
    vmul,
    vsplat,
    vstore,
    vsum,
    vzero,
)
from sescid.kinematics._kernels.torque_plan import ROW_OFFSET, ROW_PAIR
from sescid.kinematics.compile import GROUP, lazy_njit


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def _dot(a, ia, b, ib, kk):  # pragma: no cover - compiled
    """Σ_{k<kk} a.flat[ia + k] b.flat[ib + k] in 4 × 8 lanes (k = 32 t + 8 j + l in lane
    (j, l); kk a multiple of 8), joined in a fixed tree: four independent FMA chains."""
    c0 = c1 = c2 = c3 = vzero()
    k = 0
    while k + 32 <= kk:
        c0 = vfma(vload(a, ia + k), vload(b, ib + k), c0)
        c1 = vfma(vload(a, ia + k + 8), vload(b, ib + k + 8), c1)
        c2 = vfma(vload(a, ia + k + 16), vload(b, ib + k + 16), c2)
        c3 = vfma(vload(a, ia + k + 24), vload(b, ib + k + 24), c3)
        k += 32
    while k < kk:
        c0 = vfma(vload(a, ia + k), vload(b, ib + k), c0)
        k += 8
    return vsum(vadd(vadd(c0, c1), vadd(c2, c3)))


@lazy_njit(GROUP, cache=True, nogil=True)
def _joint_rows(span, tau, tau_sw, approach, ab, e):  # pragma: no cover - compiled
    """The measured joints' rows e[m] = (s, s·approach, s·τ) of the block span = (s0, w, seg),
    s the square-root weight (1 when none: tau_sw (0, J)); zero for w ≤ k < seg (ab: a (blk,)
    scratch)."""
    s0, w, seg = span
    nj = e.shape[0]
    blk = e.shape[2]
    e[:, :, w:seg] = 0.0
    tb = tau[s0 : s0 + w]
    for k in range(w):  # joint-major
        for m in range(nj):
            e[m, 2, k] = tb[k, m]
    if tau_sw.shape[0] > 0:
        sb = tau_sw[s0 : s0 + w]
        for k in range(w):
            for m in range(nj):
                e[m, 0, k] = sb[k, m]
    else:
        e[:, 0, :w] = 1.0
    friction = approach.shape[0] > 0
    ab[:] = 0.0
    if friction:
        ab[:w] = approach[s0 : s0 + w]
    for m in range(nj):
        base = 3 * m * blk
        for k in range(0, seg, 8):
            sk = vload(e, base + k)
            vstore(e, base + 2 * blk + k, vmul(vload(e, base + 2 * blk + k), sk))
            vstore(e, base + blk + k, vmul(sk, vload(ab, k)))


@lazy_njit(GROUP, cache=True, nogil=True)
def _lever(b, m, seg, mg, coef, axis, rot, e, lev):  # pragma: no cover - compiled
    """Joint m's weighted lever lev[m, q, k] = s·w_q, w = M g0 coef_b (−(R_b a_b)_y,
    (R_b a_b)_x), from body b's rows x, y (rot[b, j, q], 2 rows per j)."""
    blk = lev.shape[2]
    f = mg * coef[b]
    nf = vsplat(-f)
    pf = vsplat(f)
    a0, a1, a2 = vsplat(axis[b, 0]), vsplat(axis[b, 1]), vsplat(axis[b, 2])
    rb = b * 6 * blk  # rot[b, j, q] starts at ((b·3 + j)·2 + q)·blk
    sb = 3 * m * blk
    lb = 2 * m * blk
    for k in range(0, seg, 8):
        ax = vfma(
            vload(rot, rb + 4 * blk + k),
            a2,
            vfma(vload(rot, rb + 2 * blk + k), a1, vmul(vload(rot, rb + k), a0)),
        )
        ay = vfma(
            vload(rot, rb + 5 * blk + k),
            a2,
            vfma(vload(rot, rb + 3 * blk + k), a1, vmul(vload(rot, rb + blk + k), a0)),
        )
        sk = vload(e, sb + k)
        vstore(lev, lb + k, vmul(vmul(nf, ay), sk))
        vstore(lev, lb + blk + k, vmul(vmul(pf, ax), sk))  # fmt: skip


@lazy_njit(GROUP, cache=True, nogil=True)
def _prefix(node, seg, lev, e, sp, zp):  # pragma: no cover - compiled
    """Body c's sums down the tree from its parent p's, node = (c, p, m) (the support body's,
    index 0, are zeros): sp[c] = (xx, xy, yy) of Σ s²w wᵀ and zp[c, q·seg + k] = Σ s²τ w_q over
    the measured joints on the path support → c (m: c's joint among the measured ones, −1 if
    none)."""
    c, p, m = node
    blk = sp.shape[2]
    ldz = zp.shape[1]
    cs, ps = 3 * c * blk, 3 * max(p, 0) * blk
    cz, pz = c * ldz, max(p, 0) * ldz
    if m < 0:
        for k in range(0, seg, 8):
            vstore(sp, cs + k, vload(sp, ps + k))
            vstore(sp, cs + blk + k, vload(sp, ps + blk + k))
            vstore(sp, cs + 2 * blk + k, vload(sp, ps + 2 * blk + k))
            vstore(zp, cz + k, vload(zp, pz + k))
            vstore(zp, cz + seg + k, vload(zp, pz + seg + k))
        return
    lb, ey = 2 * m * blk, (3 * m + 2) * blk
    for k in range(0, seg, 8):
        t0 = vload(lev, lb + k)
        t1 = vload(lev, lb + blk + k)
        y = vload(e, ey + k)
        vstore(sp, cs + k, vfma(t0, t0, vload(sp, ps + k)))
        vstore(sp, cs + blk + k, vfma(t0, t1, vload(sp, ps + blk + k)))
        vstore(sp, cs + 2 * blk + k, vfma(t1, t1, vload(sp, ps + 2 * blk + k)))
        vstore(zp, cz + k, vfma(t0, y, vload(zp, pz + k)))
        vstore(zp, cz + seg + k, vfma(t1, y, vload(zp, pz + seg + k)))


@lazy_njit(GROUP, cache=True, nogil=True)
def _left_row(r, seg, lrows, v, v0, lev, e, sp, ul):  # pragma: no cover - compiled
    """Left row r of the plan into ul[r]: a column (row v0 + source of v) transformed by S_c,
    or a joint's offset or friction row (s·w_q times s or s·approach)."""
    kind, src, c = lrows[r, 0], lrows[r, 1], lrows[r, 2]
    blk = sp.shape[2]
    o = r * ul.shape[1]
    if kind == ROW_PAIR:
        xa = (v0 + src) * v.shape[1]
        sa = 3 * c * blk
        for k in range(0, seg, 8):
            sxx = vload(sp, sa + k)
            sxy = vload(sp, sa + blk + k)
            syy = vload(sp, sa + 2 * blk + k)
            x0 = vload(v, xa + k)
            x1 = vload(v, xa + seg + k)
            vstore(ul, o + k, vfma(sxy, x1, vmul(sxx, x0)))
            vstore(ul, o + seg + k, vfma(syy, x1, vmul(sxy, x0)))
        return
    ea = (3 * src + (0 if kind == ROW_OFFSET else 1)) * blk
    la = 2 * src * blk
    for k in range(0, seg, 8):
        er = vload(e, ea + k)
        vstore(ul, o + k, vmul(vload(lev, la + k), er))
        vstore(ul, o + seg + k, vmul(vload(lev, la + blk + k), er))


@lazy_njit(GROUP, cache=True, nogil=True)
def _body_torque(b, w, seg, mg, coef, axis, parent, pos, meas, own_ptr, own, lrows, rot, v, v0,
                 lev, e, sp, zp, ul, n_sesc, friction, out):  # fmt: skip  # pragma: no cover
    """Everything of moving body b the torque rows need while its rows are in L1: its joint's
    lever, its prefix sums, the left rows it owns, its columns against the targets and its
    joint's offset/friction against each other and the targets (each sum once per block)."""
    nj = e.shape[0]
    yc = n_sesc + nj * (2 if friction else 1)
    m = meas[b]
    if m >= 0:
        _lever(b, m, seg, mg, coef, axis, rot, e, lev)
    _prefix((b, parent[b], m), seg, lev, e, sp, zp)
    for t in range(own_ptr[b], own_ptr[b + 1]):
        _left_row(own[t], seg, lrows, v, v0, lev, e, sp, ul)
    ldv = v.shape[1]
    ldz = zp.shape[1]
    for lc in range(2):
        row = 2 * pos[b] + lc
        out[row, yc] += _dot(zp, b * ldz, v, (v0 + row) * ldv, 2 * seg)
    if m < 0:
        return
    lde = e.shape[2]
    e0 = (3 * m) * lde
    e1 = (3 * m + 1) * lde
    ey = (3 * m + 2) * lde
    off = n_sesc + m
    out[off, off] += _dot(e, e0, e, e0, seg)
    out[off, yc] += _dot(e, e0, e, ey, seg)
    if friction:
        fr = n_sesc + nj + m
        out[off, fr] += _dot(e, e0, e, e1, seg)
        out[fr, fr] += _dot(e, e1, e, e1, seg)
        out[fr, yc] += _dot(e, e1, e, ey, seg)
    out[yc, yc] += _dot(e, ey, e, ey, seg)


@lazy_njit(GROUP, cache=True, nogil=True)
def _blocks(seg, plan, n_sesc, ul, v, v0, out):  # pragma: no cover - compiled
    """Each block of the plan = (lrows, tasks) as tiles of 4 (or, for a multiple of 3 rows, 3)
    rows × 4 columns (indices clamped at the block's edge, only its own entries written):
    out[row, col] += Σ ul[row] v[v0 + col] over the sub-block, each pair once."""
    lrows, tasks = plan
    ldl = ul.shape[1]
    ldv = v.shape[1]
    kk = 2 * seg
    for t in range(tasks.shape[0]):
        ls, lc, rs, rc, oc = tasks[t, 0], tasks[t, 1], tasks[t, 2], tasks[t, 3], tasks[t, 4]
        nrow = 3 if (lc % 4 != 0 and lc % 3 == 0) else 4
        for r0 in range(0, lc, nrow):
            ra = ls + r0
            a0 = ra * ldl
            a1 = (ls + min(r0 + 1, lc - 1)) * ldl
            a2 = (ls + min(r0 + 2, lc - 1)) * ldl
            a3 = (ls + min(r0 + 3, lc - 1)) * ldl
            for c0 in range(0, rc, 4):
                b0 = (v0 + rs + c0) * ldv
                b1 = (v0 + rs + min(c0 + 1, rc - 1)) * ldv
                b2 = (v0 + rs + min(c0 + 2, rc - 1)) * ldv
                b3 = (v0 + rs + min(c0 + 3, rc - 1)) * ldv
                if nrow == 3:
                    t3 = sum_tile3(ul, (a0, a1, a2), v, (b0, b1, b2, b3), kk)
                    for i in range(3):
                        orow = lrows[ra + i, 3]
                        for j in range(min(4, rc - c0)):
                            ocol = oc + c0 + j
                            if orow >= n_sesc or ocol >= orow:
                                out[orow, ocol] += t3[4 * i + j]
                    continue
                tile = sum_tile(ul, (a0, a1, a2, a3), v, (b0, b1, b2, b3), kk)
                for i in range(min(4, lc - r0)):
                    orow = lrows[ra + i, 3]
                    for j in range(min(4, rc - c0)):
                        ocol = oc + c0 + j
                        if orow >= n_sesc or ocol >= orow:
                            out[orow, ocol] += tile[4 * i + j]


@lazy_njit(GROUP, cache=True, nogil=True)
def gram_fused_kernel(q, cop_y, cop_sw, tau, tau_sw, approach, mg, jcol, coef, off, parent,
                      nz_ptr, nz_k, nz_j, nz_a, root_r, u, pos, meas, axis, own_ptr, own, lrows,
                      tasks, n_sesc, blk, out_cop,
                      out_tau):  # fmt: skip  # pragma: no cover - compiled
    """The CoP's (when out_cop has rows) and the torques' augmented sums of poses q in one pass
    over the chain's rows x, y; False (nothing added) when an angle is beyond MAX_ANGLE."""
    if not angles_ok(q):
        return False
    n, nq, nb, rot, s, c1, qt = chain_buffers(q, parent, 2, blk)
    nj = tau.shape[1]
    rows = np.arange(2)
    pc = out_cop.shape[0]
    pt = 2 + n_sesc
    xv = np.zeros((max(pc, pt + 1), 2 * blk))
    xw = np.zeros((pc if cop_sw.shape[0] > 0 else 0, 2 * blk))
    lev = np.zeros((nj, 2, blk))
    e = np.zeros((nj, 3, blk))
    sp = np.zeros((nb, 3, blk))  # body 0 (the support) stays zero
    zp = np.zeros((nb, 2 * blk))
    ul = np.zeros((lrows.shape[0] + 4, 2 * blk))
    friction = approach.shape[0] > 0
    ab = np.zeros(blk)
    for s0 in range(0, n, blk):
        w, seg = block_angles(q, s0, blk, qt)
        _joint_rows((s0, w, seg), tau, tau_sw, approach, ab, e)
        for b in range(nb):
            body_columns(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                         rows, u, pos, s, c1, rot, xv)  # fmt: skip
            if b > 0:
                _body_torque(b, w, seg, mg, coef, axis, parent, pos, meas, own_ptr, own, lrows,
                             rot, xv, 2, lev, e, sp, zp, ul, n_sesc, friction,
                             out_tau)  # fmt: skip
        if pc > 0:
            cop_rows(w, seg, 2, xv)
            cop_target((s0, w, seg), cop_y, cop_sw, pt, xv, xw)
            syrk(xw if cop_sw.shape[0] > 0 else xv, pc, 2 * seg, out_cop)
        _blocks(seg, (lrows, tasks), n_sesc, ul, xv, 2, out_tau)
    return True
