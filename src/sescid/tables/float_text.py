"""Float64 → text, the shortest exact form, compiled: rows of a CSV at ~10⁷ numbers/s per core.

Each number is written exactly as Python's ``repr`` writes it (``0.1``, ``-0.0``, ``1e-05``,
``1.5e+16``, ``nan``, ``inf``): the fewest significant digits that read back to the same
float64, the closest to the exact value among them. The digits come from Ulf Adams' Ryū
algorithm ("Ryū: fast float-to-string conversion", PLDI 2018), here in numba with the 128-bit
products done in 32-bit halves; its two tables of 125-bit powers of five are computed on first
use with Python's integers. Python's ``repr`` (David Gay's dtoa) is the independent reference
the tests hold every byte to.

``format_rows(x)`` gives the CSV text (``,`` between numbers, a newline after each row) of a
(m, k) float64 block; its kernel holds no GIL, so two threads format two blocks at once.
``format_cells`` writes rows of floats and text cells (a table with a text column) the same way.
"""

from __future__ import annotations

import functools

import numpy as np

from sescid.kinematics import lazy_njit

#: bits of the powers of five in the tables (Ryū's DOUBLE_POW5_INV_BITCOUNT / _BITCOUNT)
_POW5_INV_BITS = 125
_POW5_BITS = 125
#: bytes of the longest number's text ("-2.2250738585072014e-308") plus its separator
MAX_CHARS = 25

_U0 = np.uint64(0)
_U1 = np.uint64(1)
_U2 = np.uint64(2)
_U4 = np.uint64(4)
_U5 = np.uint64(5)
_U10 = np.uint64(10)
_U32 = np.uint64(32)
_U52 = np.uint64(52)
_U64 = np.uint64(64)
_U100 = np.uint64(100)
_E4 = np.uint64(10**4)
_E8 = np.uint64(10**8)
_MASK32 = np.uint64(0xFFFFFFFF)
_MANT = np.uint64((1 << 52) - 1)
_EXPO = np.uint64(0x7FF)
_SIGN = np.uint64(63)
_HIDDEN = np.uint64(1 << 52)
_POW10 = np.array([10**i for i in range(18)], dtype=np.uint64)
#: "00" "01" … "99" as ASCII bytes
_PAIRS = np.frombuffer("".join(f"{i:02d}" for i in range(100)).encode(), dtype=np.uint8)


@functools.cache
def tables() -> tuple[np.ndarray, np.ndarray]:
    """Ryū's (342, 2) ⌊2^(b+124)/5^i⌋+1 and (326, 2) 5^i scaled to 125 bits, as (low, high)
    uint64 words (b: bits of 5^i)."""
    inv = np.empty((342, 2), dtype=np.uint64)
    for i in range(342):
        p = 5**i
        v = (1 << (p.bit_length() - 1 + _POW5_INV_BITS)) // p + 1
        inv[i] = (v & 0xFFFFFFFFFFFFFFFF, v >> 64)
    fwd = np.empty((326, 2), dtype=np.uint64)
    for i in range(326):
        p = 5**i
        shift = p.bit_length() - _POW5_BITS
        v = p >> shift if shift >= 0 else p << -shift
        fwd[i] = (v & 0xFFFFFFFFFFFFFFFF, v >> 64)
    return inv, fwd


@lazy_njit(cache=True, nogil=True, inline="always")
def _umul128_high(a, b):
    """(high, low) words of the 128-bit product of two uint64."""
    a_lo = a & _MASK32
    a_hi = a >> _U32
    b_lo = b & _MASK32
    b_hi = b >> _U32
    b00 = a_lo * b_lo
    b01 = a_lo * b_hi
    b10 = a_hi * b_lo
    b11 = a_hi * b_hi
    mid1 = b10 + (b00 >> _U32)
    mid2 = b01 + (mid1 & _MASK32)
    high = b11 + (mid1 >> _U32) + (mid2 >> _U32)
    low = ((mid2 & _MASK32) << _U32) | (b00 & _MASK32)
    return high, low


@lazy_njit(cache=True, nogil=True, inline="always")
def _shr(lo, hi, d):
    """Bits d … d+63 of the 128-bit (hi, lo), 0 < d < 64."""
    return (hi << (_U64 - d)) | (lo >> d)


@lazy_njit(cache=True, nogil=True, inline="always")
def _mul_shift_all(m2, lo, hi, j, mm_shift):
    """⌊x·M / 2^j⌋ for x = 4m₂, 4m₂ + 2 and 4m₂ − 1 − mm_shift, M = hi·2⁶⁴ + lo (Ryū's vr,
    vp, vm) from the one product P = 2m₂·M (192 bits; 118 ≤ j ≤ 125, so the low word only
    matters through carries): vr = P ≫ (j−1), vp = (P + M) ≫ (j−1), vm = (P − M) ≫ (j−1) or
    (2P − M) ≫ j."""
    h0, p0 = _umul128_high(_U2 * m2, lo)
    h1, l1 = _umul128_high(_U2 * m2, hi)
    p1 = h0 + l1
    p2 = h1 + (_U1 if p1 < h0 else _U0)
    d = np.uint64(j - 65)
    vr = _shr(p1, p2, d)
    q0 = p0 + lo  # P + M
    c = _U1 if q0 < p0 else _U0
    t = p1 + hi
    c1 = _U1 if t < p1 else _U0
    q1 = t + c
    c2 = _U1 if q1 < t else _U0
    vp = _shr(q1, p2 + c1 + c2, d)
    if mm_shift == _U1:  # P − M
        b = _U1 if p0 < lo else _U0
        t = p1 - hi
        b1 = _U1 if p1 < hi else _U0
        q1 = t - b
        b2 = _U1 if t < b else _U0
        vm = _shr(q1, p2 - b1 - b2, d)
    else:  # 2P − M
        r0 = p0 << _U1
        r1 = (p1 << _U1) | (p0 >> _SIGN)
        r2 = (p2 << _U1) | (p1 >> _SIGN)
        b = _U1 if r0 < lo else _U0
        t = r1 - hi
        b1 = _U1 if r1 < hi else _U0
        q1 = t - b
        b2 = _U1 if t < b else _U0
        vm = _shr(q1, r2 - b1 - b2, d + _U1)
    return vr, vp, vm


@lazy_njit(cache=True, nogil=True, inline="always")
def _pow5_factor(v):
    count = 0
    while v != _U0:
        if v % _U5 != _U0:
            break
        v = v // _U5
        count += 1
    return count


@lazy_njit(cache=True, nogil=True, inline="always")
def _pow5bits(e):
    return ((e * 1217359) >> 19) + 1


@lazy_njit(cache=True, nogil=True, inline="always")
def _drop_digit(vr, vp, vm, vr_tz, last):
    """One step of Ryū's general case: the last digit dropped from vr, vp and vm; ``vr_tz``
    stays True while every digit dropped before ``last`` was 0. (vr, vp, vm, vr_tz, last)."""
    return vr // _U10, vp // _U10, vm // _U10, vr_tz and last == _U0, vr % _U10


@lazy_njit(cache=True, nogil=True, inline="always")
def _shortest(mantissa, exponent, inv, fwd):
    """Ryū's d2d: (digits, decimal exponent) of the shortest exact decimal of a finite,
    non-zero double given its IEEE mantissa and biased exponent fields."""
    if exponent == 0:
        e2 = 1 - 1023 - 52 - 2
        m2 = mantissa
    else:
        e2 = np.int64(exponent) - 1023 - 52 - 2
        m2 = _HIDDEN | mantissa
    accept_bounds = (m2 & _U1) == _U0
    mv = _U4 * m2
    mm_shift = np.uint64(1) if (mantissa != _U0 or exponent <= 1) else _U0
    vm_tz = False
    vr_tz = False
    if e2 >= 0:
        q = ((e2 * 78913) >> 18) - (1 if e2 > 3 else 0)
        e10 = q
        k = _POW5_INV_BITS + _pow5bits(q) - 1
        i = -e2 + q + k
        lo = inv[q, 0]
        hi = inv[q, 1]
        vr, vp, vm = _mul_shift_all(m2, lo, hi, i, mm_shift)
        if q <= 21:
            if mv % _U5 == _U0:
                vr_tz = _pow5_factor(mv) >= q
            elif accept_bounds:
                vm_tz = _pow5_factor(mv - _U1 - mm_shift) >= q
            elif _pow5_factor(mv + _U2) >= q:
                vp -= _U1
    else:
        q = ((-e2 * 732923) >> 20) - (1 if -e2 > 1 else 0)
        e10 = q + e2
        i = -e2 - q
        k = _pow5bits(i) - _POW5_BITS
        j = q - k
        lo = fwd[i, 0]
        hi = fwd[i, 1]
        vr, vp, vm = _mul_shift_all(m2, lo, hi, j, mm_shift)
        if q <= 1:
            vr_tz = True
            if accept_bounds:
                vm_tz = mm_shift == _U1
            else:
                vp -= _U1
        elif q < 63:
            vr_tz = (mv & ((_U1 << np.uint64(q)) - _U1)) == _U0
    removed = 0
    last = _U0
    if vm_tz or vr_tz:  # the general case (rare): ties and exact bounds
        while vp // _U10 > vm // _U10:
            vm_tz = vm_tz and (vm % _U10 == _U0)
            vr, vp, vm, vr_tz, last = _drop_digit(vr, vp, vm, vr_tz, last)
            removed += 1
        if vm_tz:
            while vm % _U10 == _U0:
                vr, vp, vm, vr_tz, last = _drop_digit(vr, vp, vm, vr_tz, last)
                removed += 1
        if vr_tz and last == _U5 and vr % _U2 == _U0:
            last = np.uint64(4)  # round half to even
        up = (vr == vm and (not accept_bounds or not vm_tz)) or last >= _U5
        out = vr + (_U1 if up else _U0)
    else:
        round_up = False
        if vp // _U100 > vm // _U100:
            round_up = vr % _U100 >= np.uint64(50)
            vr //= _U100
            vp //= _U100
            vm //= _U100
            removed += 2
        while vp // _U10 > vm // _U10:
            round_up = vr % _U10 >= _U5
            vr //= _U10
            vp //= _U10
            vm //= _U10
            removed += 1
        out = vr + (_U1 if (vr == vm or round_up) else _U0)
    return out, e10 + removed


@lazy_njit(cache=True, nogil=True, inline="always")
def _n_digits(v):
    """Decimal digits of v < 10¹⁷ (most outputs have 15–17: test from the top)."""
    n = 17
    while n > 1 and v < _POW10[n - 1]:
        n -= 1
    return n


@lazy_njit(cache=True, nogil=True, inline="always")
def _put4(buf, end, v):
    """The four digits of v < 10⁴ (leading zeros kept) at ``buf[end - 4:end]``."""
    hi = np.int64(v // _U100)
    lo = np.int64(v % _U100)
    buf[end - 1] = _PAIRS[2 * lo + 1]
    buf[end - 2] = _PAIRS[2 * lo]
    buf[end - 3] = _PAIRS[2 * hi + 1]
    buf[end - 4] = _PAIRS[2 * hi]


@lazy_njit(cache=True, nogil=True, inline="always")
def _put_digits(buf, end, v, n):
    """The n decimal digits of v written to ``buf[end - n:end]`` (independent 4-digit groups,
    so the divisions do not wait on each other)."""
    while n >= 8:
        hi = v // _E8
        lo = v - hi * _E8
        _put4(buf, end, lo % _E4)
        _put4(buf, end - 4, lo // _E4)
        v = hi
        end -= 8
        n -= 8
    if n >= 4:
        _put4(buf, end, v % _E4)
        v //= _E4
        end -= 4
        n -= 4
    if n >= 2:
        r = np.int64(v % _U100)
        v //= _U100
        buf[end - 1] = _PAIRS[2 * r + 1]
        buf[end - 2] = _PAIRS[2 * r]
        end -= 2
        n -= 2
    if n:
        buf[end - 1] = 48 + np.uint8(v)


@lazy_njit(cache=True, nogil=True, inline="always")
def _write_float(bits, buf, pos, inv, fwd):
    """Write the double with these bits at ``buf[pos:]`` as Python's repr; the new position."""
    mantissa = bits & _MANT
    exponent = np.int64((bits >> _U52) & _EXPO)
    buf[pos] = 45  # '-', kept for a negative number (no branch: the sign is a coin toss)
    pos += np.int64(bits >> _SIGN)
    if exponent == 2047:
        if mantissa != _U0:
            if bits >> _SIGN:
                pos -= 1  # repr(-nan) is 'nan'
            buf[pos] = 110  # nan
            buf[pos + 1] = 97
            buf[pos + 2] = 110
        else:
            buf[pos] = 105  # inf
            buf[pos + 1] = 110
            buf[pos + 2] = 102
        return pos + 3
    if exponent == 0 and mantissa == _U0:
        buf[pos] = 48  # 0.0
        buf[pos + 1] = 46
        buf[pos + 2] = 48
        return pos + 3
    digits, e10 = _shortest(mantissa, exponent, inv, fwd)
    n = _n_digits(digits)
    point = n + e10  # value = 0.d₁d₂…dₙ × 10^point
    if point <= -4 or point > 16:  # d₁.d₂…dₙe±XX
        if n > 1:
            _put_digits(buf, pos + n + 1, digits, n)  # then d₁ moves left over the point
            buf[pos] = buf[pos + 1]
            buf[pos + 1] = 46
            pos += n + 1
        else:
            buf[pos] = 48 + np.uint8(digits)
            pos += 1
        buf[pos] = 101  # e
        x = point - 1
        if x < 0:
            buf[pos + 1] = 45
            x = -x
        else:
            buf[pos + 1] = 43
        pos += 2
        if x >= 100:
            buf[pos] = 48 + x // 100
            buf[pos + 1] = 48 + (x // 10) % 10
            buf[pos + 2] = 48 + x % 10
            return pos + 3
        buf[pos] = 48 + x // 10
        buf[pos + 1] = 48 + x % 10
        return pos + 2
    if point <= 0:  # 0.000ddd
        buf[pos] = 48
        buf[pos + 1] = 46
        buf[pos + 2] = 48  # up to three zeros, those past -point overwritten by the digits
        buf[pos + 3] = 48
        buf[pos + 4] = 48
        pos += 2 - point
        _put_digits(buf, pos + n, digits, n)
        return pos + n
    if point >= n:  # ddd000.0
        _put_digits(buf, pos + n, digits, n)
        pos += n
        for _ in range(point - n):
            buf[pos] = 48
            pos += 1
        buf[pos] = 46
        buf[pos + 1] = 48
        return pos + 2
    _put_digits(buf, pos + n + 1, digits, n)  # ddd.ddd: the integer digits move left
    for k in range(point):
        buf[pos + k] = buf[pos + k + 1]
    buf[pos + point] = 46
    return pos + n + 1


@lazy_njit(cache=True, nogil=True)
def _format_block(bits, buf, inv, fwd):
    """Rows of ``bits`` (m, k) uint64 (float64 bit patterns) as CSV text into ``buf``; the
    number of bytes written."""
    m, k = bits.shape
    pos = 0
    for i in range(m):
        for j in range(k):
            if j:
                buf[pos] = 44  # ','
                pos += 1
            pos = _write_float(bits[i, j], buf, pos, inv, fwd)
        buf[pos] = 10  # '\n'
        pos += 1
    return pos


def format_rows(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """CSV text (uint8 bytes, a buffer ``write`` takes as it is) of a (m, k) float64 block:
    every number as Python's ``repr``, ``,`` between them, a newline after each row. Holds no
    GIL while it formats. ``out``: a uint8 buffer of at least ``text_bytes(x.shape)`` to
    write into (the result is then a view of it)."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f"format_rows: expected a (m, k) block, got shape {x.shape}")
    need = text_bytes(x.shape)
    if out is None or out.size < need:
        out = np.empty(need, dtype=np.uint8)
    inv, fwd = tables()
    used = _format_block(x.view(np.uint64), out, inv, fwd)
    return out[:used]


@lazy_njit(cache=True, nogil=True)
def _format_cells_block(bits, cols, codes, cells, starts, eol, buf, inv, fwd):
    """Rows of a table as CSV text into ``buf``; the number of bytes written. Column ``c`` is
    the float ``bits[i, cols[c]]`` when ``cols[c] ≥ 0``, else the text cell numbered
    ``t = codes[i, -1 - cols[c]]`` (bytes ``cells[starts[t]:starts[t + 1]]``); rows end in
    ``eol``."""
    pos = 0
    for i in range(bits.shape[0]):
        for c in range(cols.size):
            if c:
                buf[pos] = 44  # ','
                pos += 1
            j = cols[c]
            if j >= 0:
                pos = _write_float(bits[i, j], buf, pos, inv, fwd)
            else:
                t = codes[i, -1 - j]
                for b in range(starts[t], starts[t + 1]):
                    buf[pos] = cells[b]
                    pos += 1
        for b in range(eol.size):
            buf[pos] = eol[b]
            pos += 1
    return pos


def format_cells(
    x: np.ndarray, cols: np.ndarray, codes: np.ndarray, cells: list[bytes], eol: bytes,
    out: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """CSV text (uint8 bytes) of a block of m rows whose columns are floats or text cells
    already written: column ``c`` is the float64 ``x[:, cols[c]]`` (as ``repr``) when
    ``cols[c] ≥ 0``, else ``cells[codes[:, -1 - cols[c]]]``; ``,`` between columns, ``eol``
    after each row. ``x`` (m, kf) float64, ``cols`` (k,) int64, ``codes`` (m, kt) int64;
    ``out``: a uint8 buffer to write into when large enough (the result is then a view)."""
    bits = np.ascontiguousarray(x, dtype=np.float64).view(np.uint64)
    codes = np.ascontiguousarray(codes, dtype=np.int64)
    lengths = np.fromiter(map(len, cells), dtype=np.int64, count=len(cells))
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    row = bits.shape[1] * MAX_CHARS + len(cols) + len(eol)  # + each text column's widest cell
    row += int(lengths[codes].max(axis=0).sum()) if codes.size else 0
    if out is None or out.size < bits.shape[0] * row:
        out = np.empty(bits.shape[0] * row, dtype=np.uint8)
    text, end = (np.frombuffer(bytearray(b), dtype=np.uint8) for b in (b"".join(cells), eol))
    cols = np.ascontiguousarray(cols, dtype=np.int64)
    return out[: _format_cells_block(bits, cols, codes, text, starts, end, out, *tables())]


def text_bytes(shape: tuple[int, int]) -> int:
    """Bytes that the text of a (m, k) block can take at most."""
    return shape[0] * shape[1] * MAX_CHARS + shape[0]
