"""Reading a frame's JSON line straight into its arrays: the common shape, in one compiled pass.

Why: the careful route (`orjson.loads`, then `monitor.parse.parse_frame`) builds a Python
float and a list for every number of the line and then walks them again to check and pack
them; at the reference load (80 objects with 30-point predictions, 74 KB a line) that is about
1 ms a frame, the whole live budget. Here one compiled scanner reads the line's bytes, parses
every number of the channels (ego, plan, objects, predictions) straight into an array, checks
them as `parse_frame` does, and lays the frame's arrays out in one buffer; Python only wraps
them in `Frame` values and decodes the small rest (`signals`, `odd`, `world`, unknown keys)
with orjson.

The scanner accepts only the common shape: an ASCII line; keys and strings without escapes;
ego and objects with box footprints (`length`/`width`); every object of a channel with a
`prediction` list of one length (what `parse._objects_fast` takes); no `header`; no repeated
key; integer ids of at most 18 digits. For ANY other line, and for any line with anything
wrong in it, `fast_frame` returns None and the caller takes the careful route, which accepts
or names the exact defect as it always has: the fast route never raises a defect of its own,
so kinds and messages cannot change. Where it accepts, it builds the careful route's Frame
value for value (tests/monitor/test_fast_parse*.py hold it to `parse_frame` on random frames).

Numbers: a JSON number becomes the double nearest to its decimal value, as orjson (and
Python's `float`) make it. A mantissa below 2**53 with a decimal exponent of at most 22 in
size is exact by Clinger's argument (the mantissa and the power of ten are exact doubles, and
one IEEE multiplication or division rounds correctly); other mantissas of up to 18
significant digits take the Eisel-Lemire algorithm (a 128-bit product with a truncated power
of five, exact where it answers); what neither settles (more digits, subnormal or
overflowing results) is handed back and parsed by orjson itself. An integer `-0` is 0.0, as
Python's int 0 becomes. tests/monitor/test_fast_parse_numbers.py holds the parser to orjson
bit for bit.

One quirk is kept on purpose: the careful route's own fast path for box objects with
predictions of one length (`parse._objects_fast`) does not bound their values by 1e9, where
every other value is; so a box object at x = 1e300 is accepted here too, and the same object
without a prediction is an `out-of-range` defect on both routes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, TypeGuard

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from casewatch.monitor.frames import ChannelState, Ego, Frame, Objects
from casewatch.monitor.jit import KERNEL_OPTIONS, kernel
from casewatch.monitor.parse import FrameDefect, frame_extras

try:  # the fast route needs orjson for the small rest of a line; without it, the careful one
    import orjson
except ImportError:  # pragma: no cover - depends on the environment
    orjson = None  # type: ignore[assignment]

#: Scanner outcomes.
_OK, _FALLBACK, _HARD = 0, 1, 2

#: Largest magnitude of ego and plan values (parse.MAX_MAGNITUDE; box objects are not held
#: to it by the careful route's own fast path, and so not here).
_MAX = 1e9

#: Nesting a skipped value (an unknown key's, `signals`, `world`, `odd`) may have: far below
#: orjson's 1024 and Python's recursion limit, so decoding it alone and within the line agree.
_MAX_SKIP_DEPTH = 200

#: Most numbers of a line left to orjson (see the module docstring); a line with more takes
#: the careful route.
_MAX_HARD = 256

#: Most values a line may leave to orjson (unknown keys, `signals`, `world`, `odd`).
_MAX_SPANS = 64

#: Most channels a fast frame has (a frame with more takes the careful route).
_MAX_CHANNELS = 16

# Key codes (one table for every level: each level reads its own, the rest are unknown keys).
_K_OTHER = 0
_K_X, _K_Y, _K_YAW, _K_VX, _K_VY, _K_LENGTH, _K_WIDTH = 1, 2, 3, 4, 5, 6, 7
_K_ID, _K_CLS, _K_PREDICTION, _K_POLYGON = 8, 9, 10, 11
_K_EGO, _K_PLAN, _K_OBJECTS = 12, 13, 14
_K_T, _K_CHANNELS, _K_SIGNALS, _K_ODD, _K_WORLD, _K_HEADER = 15, 16, 17, 18, 19, 20

#: Span kinds handed to Python (orjson decodes them); 0 is an unknown key's value.
SPAN_NAMES = ("", "signals", "odd", "world")
_ANY = np.int64(0)  # that kind as an int64 (a literal 0 would take its own compiled variant)

# Object table columns: vals index of x, y, yaw, vx, vy, length, width (-1 absent), id span
# (start, end; -1 absent), cls span (-1 absent), prediction (first vals index, points; -1
# absent).
_O_ID, _O_ID_END, _O_CLS, _O_CLS_END, _O_PRED, _O_PRED_N = 7, 8, 9, 10, 11, 12
_O_COLS = 13
# Channel table columns: name span, ego vals indices (x .. width), ego seen, plan (first vals
# index, points), objects (first row of the object table, count).
_C_NAME, _C_NAME_END, _C_EGO, _C_HAS_EGO, _C_PLAN, _C_PLAN_N, _C_OBJ, _C_OBJ_N = (
    0,
    1,
    2,
    9,
    10,
    11,
    12,
    13,
)
_C_COLS = 14

# Exact powers of ten as doubles (10**22 is the largest exact one).
_P10 = np.array([10.0**i for i in range(23)])


def _powers_of_five() -> np.ndarray:
    """The Eisel-Lemire table: for q in [-342, 308], 5**q as a 128-bit value with its top bit
    set, truncated (q >= 0) or rounded up (q < 0), as (high, low) 64-bit halves; the same
    numbers as fast_float's table (its generation script, in integers)."""
    rows = []
    for q in range(-342, 0):
        power5 = 5**-q
        z = power5.bit_length()  # the least z with 2**z >= 5**-q (never a power of two)
        b = z + 127 if q >= -27 else 2 * z + 2 * 64
        c = 2**b // power5 + 1
        rows.append(c >> max(c.bit_length() - 128, 0))  # halved until below 2**128
    for q in range(0, 309):
        power5 = 5**q
        shift = power5.bit_length() - 128  # doubled or halved to 128 bits, truncated
        rows.append(power5 >> shift if shift > 0 else power5 << -shift)
    table = np.empty((len(rows), 2), dtype=np.uint64)
    for i, c in enumerate(rows):
        table[i, 0] = c >> 64
        table[i, 1] = c & ((1 << 64) - 1)
    return table


_POW5 = _powers_of_five()


def _inline(fn: Any) -> Any:
    """A kernel numba inlines into its callers (numba's IR inlining: LLVM did not inline these
    small helpers across numba's calling convention, which doubled the scan's time)."""
    return njit(inline="always", **KERNEL_OPTIONS)(fn)


def _entry(fn: Any) -> Any:
    """monitor.jit's settings for a kernel Python calls, compiled on its first call (from
    numba's cache after a machine's first run, `casewatch warm-up`), not when the module is
    imported: a command that reads no frame (`casewatch check`) compiles nothing.
    `monitor.warmup.warm_up` reads sample lines through it, so a run compiles nothing on its
    first line. The kernels it calls are compiled into it (monitor.jit: a kernel calls only
    kernels of its own module)."""
    return njit(**KERNEL_OPTIONS)(fn)


@intrinsic
def _data_pointer(typingctx: Any, array: Any) -> Any:  # pragma: no cover - compiled
    """A pointer to an array's first element, for the scanner to read the line through.

    Why not the array: numba counts references to an array passed into a helper it inlines
    (an incref and a decref, two calls, around every number parsed) and wraps every signed
    index for negative values; a pointer has neither, which halves the cost of a number
    (measured: 12.9 -> 6.9 ns). The array outlives the pointer: it is the caller's argument."""
    signature = types.CPointer(array.dtype)(array)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return context.make_array(sig.args[0])(context, builder, args[0]).data

    return signature, codegen


@kernel
def _mul128(a, b):  # pragma: no cover - compiled
    """(high, low) 64-bit halves of the 128-bit product of two uint64."""
    mask = np.uint64(0xFFFFFFFF)
    s32 = np.uint64(32)
    a_lo = a & mask
    a_hi = a >> s32
    b_lo = b & mask
    b_hi = b >> s32
    lo_lo = a_lo * b_lo
    hi_lo = a_hi * b_lo
    lo_hi = a_lo * b_hi
    hi_hi = a_hi * b_hi
    cross = (lo_lo >> s32) + (hi_lo & mask) + lo_hi
    high = hi_hi + (hi_lo >> s32) + (cross >> s32)
    low = (cross << s32) | (lo_lo & mask)
    return high, low


@kernel
def _clz(x):  # pragma: no cover - compiled
    n = 0
    top = np.uint64(1) << np.uint64(63)
    while n < 64 and (x & top) == np.uint64(0):
        x = x << np.uint64(1)
        n += 1
    return n


@kernel
def _eisel_lemire(w, q):  # pragma: no cover - compiled
    """The double nearest to w * 10**q (w > 0, at most 19 digits) as (ok, value); ok is False
    where the algorithm does not settle it here (subnormal, overflow, out of the table)."""
    if q < -342 or q > 308:
        return False, 0.0
    lz = _clz(w)
    w = w << np.uint64(lz)
    index = q + 342
    high, low = _mul128(w, _POW5[index, 0])
    if (high & np.uint64(0x1FF)) == np.uint64(0x1FF):
        high2, _ = _mul128(w, _POW5[index, 1])
        new_low = low + high2
        if high2 > new_low:
            high += np.uint64(1)
        low = new_low
        if low == np.uint64(0xFFFFFFFFFFFFFFFF) and (q < -27 or q > 55):
            return False, 0.0  # the product cannot decide (fast_float's fallback)
    upperbit = np.int64(high >> np.uint64(63))
    mantissa = high >> np.uint64(upperbit + 9)
    power2 = (((152170 + 65536) * q) >> 16) + 63 + upperbit - lz + 1023
    if power2 <= 0:
        return False, 0.0  # subnormal: left to orjson
    if (
        low <= np.uint64(1)
        and q >= -4
        and q <= 23
        and (mantissa & np.uint64(3)) == np.uint64(1)
        and (mantissa << np.uint64(upperbit + 9)) == high
    ):
        mantissa &= ~np.uint64(1)  # a tie: round to even
    mantissa += mantissa & np.uint64(1)
    mantissa >>= np.uint64(1)
    if mantissa >= (np.uint64(1) << np.uint64(53)):
        mantissa = np.uint64(1) << np.uint64(52)
        power2 += 1
    if power2 >= 0x7FF:
        return False, 0.0  # overflow to infinity: left to orjson
    # a normal double: the 53-bit mantissa (implicit bit included) times a power of two, exact
    return True, math.ldexp(float(mantissa), power2 - 1075)


@kernel
def _slow_value(m, e10):  # pragma: no cover - compiled
    """w * 10**e10 for a mantissa Clinger's fast path does not take: (ok, value)."""
    return _eisel_lemire(np.uint64(m), e10)


@_inline
def _number(buf, p):  # pragma: no cover - compiled
    """Parse the JSON number at p: (end, value, state, is_int); state 0 bad, 1 parsed, 2 left
    to orjson (the value is then a placeholder). A number of more than 18 significant digits
    (m holds them below 2**63; beyond, it wraps and is not used) is left to orjson."""
    neg = buf[p] == 45  # '-'
    if neg:
        p += 1
    c = buf[p]
    m = 0
    digits = p
    if c == 48:  # '0': no digit may follow (the caller sees it as a bad delimiter)
        p += 1
    elif 49 <= c <= 57:
        while 48 <= c <= 57:
            m = m * 10 + (c - 48)
            p += 1
            c = buf[p]
    else:
        return p, 0.0, 0, False
    int_digits = p - digits
    sig = 0 if m == 0 else int_digits  # significant digits so far
    is_int = True
    frac = 0
    c = buf[p]
    if c == 46:  # '.'
        is_int = False
        p += 1
        c = buf[p]
        if not 48 <= c <= 57:
            return p, 0.0, 0, False
        start = p
        if sig == 0:
            while c == 48:  # leading zeros of the fraction: not significant
                p += 1
                c = buf[p]
        digits = p
        while 48 <= c <= 57:
            m = m * 10 + (c - 48)
            p += 1
            c = buf[p]
        frac = p - start
        sig += p - digits
    exp = 0
    if c == 101 or c == 69:  # 'e' / 'E'
        is_int = False
        p += 1
        c = buf[p]
        eneg = c == 45
        if c == 43 or c == 45:
            p += 1
            c = buf[p]
        if not 48 <= c <= 57:
            return p, 0.0, 0, False
        while 48 <= c <= 57:
            if exp < 100000:
                exp = exp * 10 + (c - 48)
            p += 1
            c = buf[p]
        if eneg:
            exp = -exp
    if is_int and int_digits > 18:
        return p, 0.0, 0, True  # beyond 64 bits orjson reads an integer as a float
    if sig > 18 or int_digits > 18:
        return p, 0.0, 2, is_int  # more digits than m holds: left to orjson
    if m == 0:
        if neg and not is_int:
            return p, -0.0, 1, is_int
        return p, 0.0, 1, is_int  # the integer -0 is Python's int 0
    e10 = exp - frac
    if m <= 9007199254740992 and -22 <= e10 <= 22:
        # one correctly rounded operation on exact operands (Clinger)
        v = float(m) * _P10[e10] if e10 >= 0 else float(m) / _P10[-e10]
        return p, -v if neg else v, 1, is_int
    ok, v = _slow_value(m, e10)
    if not ok:
        return p, 0.0, 2, is_int
    return p, -v if neg else v, 1, is_int


@kernel
def _ws(buf, p):  # pragma: no cover - compiled
    """The first position from p that is not JSON whitespace."""
    c = buf[p]
    while c == 32 or c == 10 or c == 13 or c == 9:
        p += 1
        c = buf[p]
    return p


@kernel
def _string(buf, p):  # pragma: no cover - compiled
    """A plain string at p (no escapes, printable ASCII): (ok, content start, content end,
    position after the closing quote)."""
    if buf[p] != 34:
        return False, 0, 0, p
    p += 1
    s = p
    while True:
        c = buf[p]
        if c == 34:
            return True, s, p, p + 1
        if c < 32 or c == 92 or c > 126:
            return False, 0, 0, p
        p += 1


@kernel
def _skip(buf, p, n):  # pragma: no cover - compiled
    """The end of the JSON value at p (not checked: orjson decodes the span), or -1."""
    c = buf[p]
    if c == 34:
        p += 1
        while p < n:
            c = buf[p]
            if c == 34:
                return p + 1
            if c == 92:
                p += 1
            p += 1
        return -1
    if c == 123 or c == 91:
        depth = 0
        while p < n:
            c = buf[p]
            if c == 34:
                p += 1
                while p < n and buf[p] != 34:
                    if buf[p] == 92:
                        p += 1
                    p += 1
                if p >= n:
                    return -1
            elif c == 123 or c == 91:
                depth += 1
                if depth > _MAX_SKIP_DEPTH:
                    return -1
            elif c == 125 or c == 93:
                depth -= 1
                if depth == 0:
                    return p + 1
            p += 1
        return -1
    s = p
    while p < n:
        c = buf[p]
        if c == 44 or c == 93 or c == 125 or c == 32 or c == 10 or c == 13 or c == 9:
            break
        p += 1
    return p if p > s else -1


@kernel
def _eq(buf, s, lit):  # pragma: no cover - compiled
    for i in range(len(lit)):  # noqa: SIM110 - a generator is not compiled
        if buf[s + i] != lit[i]:
            return False
    return True


_L_ID = np.frombuffer(b"id", np.uint8)
_L_VX = np.frombuffer(b"vx", np.uint8)
_L_VY = np.frombuffer(b"vy", np.uint8)
_L_EGO = np.frombuffer(b"ego", np.uint8)
_L_YAW = np.frombuffer(b"yaw", np.uint8)
_L_CLS = np.frombuffer(b"cls", np.uint8)
_L_ODD = np.frombuffer(b"odd", np.uint8)
_L_PLAN = np.frombuffer(b"plan", np.uint8)
_L_WIDTH = np.frombuffer(b"width", np.uint8)
_L_WORLD = np.frombuffer(b"world", np.uint8)
_L_LENGTH = np.frombuffer(b"length", np.uint8)
_L_HEADER = np.frombuffer(b"header", np.uint8)
_L_OBJECTS = np.frombuffer(b"objects", np.uint8)
_L_SIGNALS = np.frombuffer(b"signals", np.uint8)
_L_POLYGON = np.frombuffer(b"polygon", np.uint8)
_L_CHANNELS = np.frombuffer(b"channels", np.uint8)
_L_PREDICTION = np.frombuffer(b"prediction", np.uint8)


@kernel
def _key(buf, s, e):  # pragma: no cover - compiled
    """The code of the key in buf[s:e] (_K_OTHER when the format does not name it)."""
    size = e - s
    if size == 1:
        c = buf[s]
        if c == 116:
            return _K_T
        if c == 120:
            return _K_X
        if c == 121:
            return _K_Y
    elif size == 2:
        if _eq(buf, s, _L_ID):
            return _K_ID
        if _eq(buf, s, _L_VX):
            return _K_VX
        if _eq(buf, s, _L_VY):
            return _K_VY
    elif size == 3:
        if _eq(buf, s, _L_YAW):
            return _K_YAW
        if _eq(buf, s, _L_CLS):
            return _K_CLS
        if _eq(buf, s, _L_EGO):
            return _K_EGO
        if _eq(buf, s, _L_ODD):
            return _K_ODD
    elif size == 4:
        if _eq(buf, s, _L_PLAN):
            return _K_PLAN
    elif size == 5:
        if _eq(buf, s, _L_WIDTH):
            return _K_WIDTH
        if _eq(buf, s, _L_WORLD):
            return _K_WORLD
    elif size == 6:
        if _eq(buf, s, _L_LENGTH):
            return _K_LENGTH
        if _eq(buf, s, _L_HEADER):
            return _K_HEADER
    elif size == 7:
        if _eq(buf, s, _L_OBJECTS):
            return _K_OBJECTS
        if _eq(buf, s, _L_SIGNALS):
            return _K_SIGNALS
        if _eq(buf, s, _L_POLYGON):
            return _K_POLYGON
    elif size == 8:
        if _eq(buf, s, _L_CHANNELS):
            return _K_CHANNELS
    elif size == 10 and _eq(buf, s, _L_PREDICTION):
        return _K_PREDICTION
    return _K_OTHER


@kernel
def _member(buf, p):  # pragma: no cover - compiled
    """An object member's `"key":` at p: (ok, key code, key start, key end, position of the
    value)."""
    ok, s, e, p = _string(buf, p)
    if not ok:
        return False, 0, 0, 0, p
    p = _ws(buf, p)
    if buf[p] != 58:  # ':'
        return False, 0, 0, 0, p
    return True, _key(buf, s, e), s, e, _ws(buf, p + 1)


@_inline
def _next(buf, p, close):  # pragma: no cover - compiled
    """After a member or element: (state, position); state 1 another follows (position at
    it), 0 the container closes with `close` (position after it), -1 anything else."""
    p = _ws(buf, p)
    c = buf[p]
    if c == 44:
        return 1, _ws(buf, p + 1)
    if c == close:
        return 0, p + 1
    return -1, p


@_inline
def _open(buf, p, opening, close):  # pragma: no cover - compiled
    """At p a container opening with `opening`: (state, position); state 1 a first member
    follows (position at it), 0 the container is empty (position after it), -1 not one."""
    if buf[p] != opening:
        return -1, p
    p = _ws(buf, p + 1)
    if buf[p] == close:
        return 0, p + 1
    return 1, p


@kernel
def _grow(table, rows):  # pragma: no cover - compiled
    """`table` with room for at least `rows` rows (doubled, contents kept)."""
    if rows <= table.shape[0]:
        return table
    bigger = np.empty((max(rows, 2 * table.shape[0]), table.shape[1]), dtype=table.dtype)
    for i in range(table.shape[0]):  # loops: numba compiles slice assignment slowly
        for j in range(table.shape[1]):
            bigger[i, j] = table[i, j]
    return bigger


@kernel
def _put_number(buf, p, vals, nv, hard, nh):  # pragma: no cover - compiled
    """Parse a number into vals[nv]; (end, ok, hard count). A number left to orjson goes to
    the `hard` table (vals index, token start, end); a full table is a refusal."""
    end, v, state, _ = _number(buf, p)
    if state == 0:
        return end, False, nh
    vals[nv] = v
    if state == 2:
        if nh == hard.shape[0]:
            return end, False, nh
        hard[nh, 0] = nv
        hard[nh, 1] = p
        hard[nh, 2] = end
        nh += 1
    return end, True, nh


@kernel
def _points(buf, p, vals, nv, hard, nh):  # pragma: no cover - compiled
    """A list of [a, b, c] number triples at p: (end, ok, points, nv, nh); the numbers go to
    vals in order."""
    points = 0
    state, p = _open(buf, p, 91, 93)
    if state <= 0:
        return p, state == 0, 0, nv, nh
    while True:
        if buf[p] != 91:
            return p, False, points, nv, nh
        for k in range(3):
            p = _ws(buf, p + 1)
            # _put_number's work, written out: this loop reads nearly every number of a line
            end, v, state, _ = _number(buf, p)
            if state == 0:
                return end, False, points, nv, nh
            vals[nv] = v
            if state == 2:
                if nh == hard.shape[0]:
                    return end, False, points, nv, nh
                hard[nh, 0] = nv
                hard[nh, 1] = p
                hard[nh, 2] = end
                nh += 1
            p = _ws(buf, end)
            nv += 1
            if buf[p] != (44 if k < 2 else 93):
                return p, False, points, nv, nh
        points += 1
        state, p = _next(buf, p + 1, 93)
        if state < 0:
            return p, False, points, nv, nh
        if state == 0:
            return p, True, points, nv, nh


@kernel
def _integer_id(buf, p):  # pragma: no cover - compiled
    """An integer id at p whose text is str() of its int: (ok, end). At most 18 digits (orjson
    reads longer ones by its own type rules), no leading zero, not '-0' (whose int is 0), not
    followed by a fraction or an exponent (a float id is a careful-route defect)."""
    s = p
    if buf[p] == 45:
        p += 1
    if buf[p] == 48:
        p += 1
        ok = p - s == 1  # '0' alone
    else:
        d = p
        while 48 <= buf[p] <= 57:
            p += 1
        ok = 0 < p - d <= 18
    c = buf[p]
    return ok and c != 46 and c != 101 and c != 69 and not 48 <= c <= 57, p


@_inline
def _add_span(spans, ns, kind, s, e):  # pragma: no cover - compiled
    """Record a value left to orjson; False when the (fixed) table is full."""
    if ns == spans.shape[0]:
        return False, ns
    spans[ns, 0] = kind
    spans[ns, 1] = s
    spans[ns, 2] = e
    return True, ns + 1


@kernel
def _other(buf, p, n, spans, ns, kind):  # pragma: no cover - compiled
    """Skip a value left to orjson and record its span: (end, ok, span count)."""
    end = _skip(buf, p, n)
    if end < 0:
        return p, False, ns
    ok, ns = _add_span(spans, ns, kind, p, end)
    return end, ok, ns


@kernel
def _scan_ego(buf, p, n, vals, nv, hard, nh, chans, c, spans, ns):  # pragma: no cover
    """A channel's ego object at p: (end, ok, nv, nh, ns)."""
    state, p = _open(buf, p, 123, 125)
    if state < 0:
        return p, False, nv, nh, ns
    chans[c, _C_HAS_EGO] = 1
    while state == 1:
        ok, code, _, _, p = _member(buf, p)
        if not ok:
            return p, False, nv, nh, ns
        if _K_X <= code <= _K_WIDTH:
            col = _C_EGO + code - _K_X
            if chans[c, col] >= 0:
                return p, False, nv, nh, ns  # a repeated key
            p, ok, nh = _put_number(buf, p, vals, nv, hard, nh)
            chans[c, col] = nv
            nv += 1
        elif code == _K_POLYGON:
            return p, False, nv, nh, ns
        else:
            p, ok, ns = _other(buf, p, n, spans, ns, _ANY)
        if not ok:
            return p, False, nv, nh, ns
        state, p = _next(buf, p, 125)
    return p, state == 0, nv, nh, ns


@kernel
def _scan_object(buf, p, n, vals, nv, hard, nh, objs, row, spans, ns):  # pragma: no cover
    """One object at p into row `row` of the object table: (end, ok, nv, nh, ns)."""
    for col in range(_O_COLS):
        objs[row, col] = -1
    state, p = _open(buf, p, 123, 125)
    if state < 0:
        return p, False, nv, nh, ns
    while state == 1:
        ok, code, _, _, p = _member(buf, p)
        if not ok:
            return p, False, nv, nh, ns
        if _K_X <= code <= _K_WIDTH:
            col = code - _K_X
            if objs[row, col] >= 0:
                return p, False, nv, nh, ns
            p, ok, nh = _put_number(buf, p, vals, nv, hard, nh)
            objs[row, col] = nv
            nv += 1
        elif code == _K_ID:
            if objs[row, _O_ID] >= 0:
                return p, False, nv, nh, ns
            s = p
            if buf[p] == 34:
                ok, s, e, p = _string(buf, p)
            else:
                ok, e = _integer_id(buf, p)
                p = e
            objs[row, _O_ID] = s
            objs[row, _O_ID_END] = e
        elif code == _K_CLS:
            if objs[row, _O_CLS] >= 0:
                return p, False, nv, nh, ns
            ok, s, e, p = _string(buf, p)
            objs[row, _O_CLS] = s
            objs[row, _O_CLS_END] = e
        elif code == _K_PREDICTION:
            if objs[row, _O_PRED] >= 0:
                return p, False, nv, nh, ns
            objs[row, _O_PRED] = nv
            p, ok, points, nv, nh = _points(buf, p, vals, nv, hard, nh)
            objs[row, _O_PRED_N] = points
        elif code == _K_POLYGON:
            return p, False, nv, nh, ns
        else:
            p, ok, ns = _other(buf, p, n, spans, ns, _ANY)
        if not ok:
            return p, False, nv, nh, ns
        state, p = _next(buf, p, 125)
    return p, state == 0, nv, nh, ns


@kernel
def _scan_channel(buf, p, n, vals, nv, hard, nh, chans, c, objs, no, spans, ns):  # pragma: no cover
    """One channel's object at p into row c of the channel table: (end, ok, nv, nh, ns, no,
    objs); the object table grows as needed."""
    chans[c, _C_PLAN] = nv
    chans[c, _C_PLAN_N] = 0
    chans[c, _C_OBJ] = no
    chans[c, _C_OBJ_N] = 0
    chans[c, _C_HAS_EGO] = 0
    seen = 0
    state, p = _open(buf, p, 123, 125)
    if state < 0:
        return p, False, nv, nh, ns, no, objs
    while state == 1:
        ok, code, _, _, p = _member(buf, p)
        if not ok:
            return p, False, nv, nh, ns, no, objs
        if code in (_K_EGO, _K_PLAN, _K_OBJECTS):
            if seen & (1 << code):
                return p, False, nv, nh, ns, no, objs
            seen |= 1 << code
        if code == _K_EGO:
            p, ok, nv, nh, ns = _scan_ego(buf, p, n, vals, nv, hard, nh, chans, c, spans, ns)
        elif code == _K_PLAN:
            chans[c, _C_PLAN] = nv
            p, ok, points, nv, nh = _points(buf, p, vals, nv, hard, nh)
            chans[c, _C_PLAN_N] = points
        elif code == _K_OBJECTS:
            chans[c, _C_OBJ] = no
            state, p = _open(buf, p, 91, 93)
            ok = state >= 0
            while state == 1:
                if no == objs.shape[0]:
                    objs = _grow(objs, no + 1)
                p, ok, nv, nh, ns = _scan_object(buf, p, n, vals, nv, hard, nh, objs, no, spans, ns)
                if not ok:
                    break
                no += 1
                state, p = _next(buf, p, 93)
                ok = state >= 0
            chans[c, _C_OBJ_N] = no - chans[c, _C_OBJ]
        else:
            p, ok, ns = _other(buf, p, n, spans, ns, _ANY)
        if not ok:
            return p, False, nv, nh, ns, no, objs
        state, p = _next(buf, p, 125)
    return p, state == 0, nv, nh, ns, no, objs


@kernel
def _scan(buf, n):  # pragma: no cover - compiled
    """Scan a frame line (buf[n] is a 0 sentinel; `buf` points to it, see _data_pointer).
    Returns (status, vals, t index, chans, channel count, objs, object count, hard, hard
    count, spans, span count)."""
    # counters start as int64, not as the literal 0: numba would first compile every kernel
    # they are passed to for the literal too (twice the compile time, never used)
    zero = np.int64(0)
    vals = np.empty(n // 2 + 2)
    nv = zero
    hard = np.empty((_MAX_HARD, 3), dtype=np.int64)
    nh = zero
    spans = np.empty((_MAX_SPANS, 3), dtype=np.int64)
    ns = zero
    chans = np.full((_MAX_CHANNELS, _C_COLS), -1, dtype=np.int64)
    nc = zero
    objs = np.empty((64, _O_COLS), dtype=np.int64)
    no = zero
    t_index = -1
    seen = 0
    ok = True
    state, p = _open(buf, _ws(buf, zero), 123, 125)
    while state == 1:
        ok, code, _, _, p = _member(buf, p)
        if not ok:
            break
        if code >= _K_T:  # a frame-level key: once only (the careful route decides repeats)
            if seen & (1 << code):
                ok = False
                break
            seen |= 1 << code
        if code == _K_T:
            p, ok, nh = _put_number(buf, p, vals, nv, hard, nh)
            t_index = nv
            nv += 1
        elif code == _K_CHANNELS:
            cstate, p = _open(buf, p, 123, 125)
            ok = cstate >= 0
            while cstate == 1:
                if nc == _MAX_CHANNELS:
                    ok = False
                    break
                ok, _, s, e, p = _member(buf, p)
                if not ok:
                    break
                chans[nc, _C_NAME] = s
                chans[nc, _C_NAME_END] = e
                p, ok, nv, nh, ns, no, objs = _scan_channel(
                    buf, p, n, vals, nv, hard, nh, chans, nc, objs, no, spans, ns
                )
                if not ok:
                    break
                nc += 1
                cstate, p = _next(buf, p, 125)
                ok = cstate >= 0
        elif code == _K_HEADER:
            ok = False
        else:
            kind = zero
            if code == _K_SIGNALS:
                kind = 1
            elif code == _K_ODD:
                kind = 2
            elif code == _K_WORLD:
                kind = 3
            p, ok, ns = _other(buf, p, n, spans, ns, kind)
        if not ok:
            break
        state, p = _next(buf, p, 125)
    status = _HARD if nh else _OK
    if not ok or state != 0 or _ws(buf, p) != n or t_index < 0 or not (seen & (1 << _K_CHANNELS)):
        status = _FALLBACK
    return (status, vals, t_index, chans, nc, objs, no, hard, nh, spans, ns)


@kernel
def _finite(v):  # pragma: no cover - compiled
    return v - v == 0.0


_UNKNOWN = np.frombuffer(b"unknown", np.uint8)


# The output buffer `_build` lays a frame out in (float64 words). It starts with a header of
# int64 words (the same memory viewed as int64), then the frame's numbers in five regions, each
# holding one shape for every channel, so that Python makes each of a frame's arrays with one
# slice of a region (see `fast_frame`), then the strings as bytes.
_H_STATUS, _H_LEN, _H_NC, _H_K, _H_NS, _H_NBYTES = 0, 1, 2, 3, 4, 5
_H_R1, _H_YAW, _H_R2, _H_R4, _H_R3, _H_ROWS3, _H_STR = 6, 7, 8, 9, 10, 11, 12
_H_FIXED = 13
#: Per-channel header row: plan (first row of region 3, points), objects (first object of
#: the frame's object order, count, prediction points), first prediction row of region 3.
_CH_PLAN, _CH_N, _CH_OBJ, _CH_K, _CH_P, _CH_PRED = 0, 1, 2, 3, 4, 5
_CH_COLS = 6
_REFUSE = np.int64(_FALLBACK)  # as an int64 (a literal would take its own compiled variant)
_H_FIXED_I = np.int64(_H_FIXED)
_OK_I = np.int64(_OK)


@kernel
def _fill(vals, t_index, chans, nc, objs, out, o1, oy, o2, o4, o3, kk):  # pragma: no cover
    """_build's checks and numbers: False at the first value parse_frame would not take.

    Region 1 (o1): t, then per channel x, y, yaw, vx, vy, half length, half width of the ego.
    Region yaw (oy): every object's yaw, in the frame's object order. Region 2 (o2, rows of 2):
    every object's position, then every velocity, then every (half length, half width).
    Region 4 (o4, 4x2 blocks): each channel's ego footprint, then every object's. Region 3 (o3,
    rows of 3): per channel its plan, then its objects' predictions."""
    out[o1] = vals[t_index]
    row3 = 0
    first = 0
    for c in range(nc):
        # ego: x, y, yaw required; vx, vy default 0; a box of positive size; all within 1e9
        e0 = o1 + 1 + 7 * c
        for f in range(7):
            idx = chans[c, _C_EGO + f]
            if idx < 0:
                if f == 3 or f == 4:
                    v = 0.0
                else:
                    return False
            else:
                v = vals[idx]
            if not _finite(v) or abs(v) > _MAX:
                return False
            if f < 5:
                out[e0 + f] = v
        length = vals[chans[c, _C_EGO + 5]]
        width = vals[chans[c, _C_EGO + 6]]
        if length <= 0 or width <= 0:
            return False
        hl = 0.5 * length
        hw = 0.5 * width
        out[e0 + 5] = hl
        out[e0 + 6] = hw
        f0 = o4 + 8 * c
        out[f0] = hl
        out[f0 + 1] = hw
        out[f0 + 2] = -hl
        out[f0 + 3] = hw
        out[f0 + 4] = -hl
        out[f0 + 5] = -hw
        out[f0 + 6] = hl
        out[f0 + 7] = -hw
        # plan: finite, within 1e9, dt from >= 0 strictly increasing (np.diff(dt) > 0)
        p0 = o3 + 3 * row3
        v0 = chans[c, _C_PLAN]
        npl = chans[c, _C_PLAN_N]
        for j in range(3 * npl):
            v = vals[v0 + j]
            if not _finite(v) or abs(v) > _MAX:
                return False
            out[p0 + j] = v
        for j in range(npl):
            dt = out[p0 + 3 * j]
            if j == 0:
                if dt < 0:
                    return False
            elif not dt - out[p0 + 3 * (j - 1)] > 0:
                return False
        row3 += npl
        # objects, as parse._box_objects checks them (finite, box > 0, prediction dt; no
        # magnitude bound: the careful route's own fast path has none for box objects)
        k = chans[c, _C_OBJ_N]
        o0 = chans[c, _C_OBJ]
        pts = objs[o0, _O_PRED_N] if k else 0
        for i in range(k):
            row = o0 + i
            x = vals[objs[row, 0]]
            y = vals[objs[row, 1]]
            a = 0.0 if objs[row, 2] < 0 else vals[objs[row, 2]]
            vx = 0.0 if objs[row, 3] < 0 else vals[objs[row, 3]]
            vy = 0.0 if objs[row, 4] < 0 else vals[objs[row, 4]]
            length = vals[objs[row, 5]]
            width = vals[objs[row, 6]]
            if not (
                _finite(x)
                and _finite(y)
                and _finite(a)
                and _finite(vx)
                and _finite(vy)
                and _finite(length)
                and _finite(width)
            ):
                return False
            if not (length > 0.0 and width > 0.0):
                return False
            q0 = objs[row, _O_PRED]
            d0 = o3 + 3 * row3
            for j in range(3 * pts):
                v = vals[q0 + j]
                if not _finite(v):
                    return False
                out[d0 + j] = v
            for j in range(pts):
                if j == 0:
                    if not out[d0] >= 0.0:
                        return False
                elif not out[d0 + 3 * j] > out[d0 + 3 * (j - 1)]:
                    return False
            row3 += pts
            g = first + i  # the object's place in the frame's object order
            hl = 0.5 * length
            hw = 0.5 * width
            out[oy + g] = a
            out[o2 + 2 * g] = x
            out[o2 + 2 * g + 1] = y
            out[o2 + 2 * (kk + g)] = vx
            out[o2 + 2 * (kk + g) + 1] = vy
            out[o2 + 2 * (2 * kk + g)] = hl
            out[o2 + 2 * (2 * kk + g) + 1] = hw
            f0 = o4 + 8 * (nc + g)
            out[f0] = hl
            out[f0 + 1] = hw
            out[f0 + 2] = -hl
            out[f0 + 3] = hw
            out[f0 + 4] = -hl
            out[f0 + 5] = -hw
            out[f0 + 6] = hl
            out[f0 + 7] = -hw
        first += k
    return True


@kernel
def _refused(status):  # pragma: no cover - compiled
    """The output of a line the fast route does not take: (status, header length, buffer)."""
    out = np.zeros(_H_FIXED)
    out.view(np.int64)[_H_STATUS] = status
    return status, _H_FIXED_I, out


@kernel
def _put_bytes(text, at, buf, s, e):  # pragma: no cover - compiled
    """Copy buf[s:e] into text at `at`; the position after it."""
    for q in range(s, e):
        text[at] = buf[q]
        at += 1
    return at


@_entry
def _build(buf, vals, t_index, chans, nc, objs, spans, ns):  # pragma: no cover - compiled
    """Check the scanned numbers as parse_frame does and lay the frame out in one buffer.

    Returns (status, header length, out): `out` starts with the header (int64 words: the
    _H_* fields, the spans as (kind, start, end), then a _CH_COLS row per channel), then the
    regions `_fill` writes, then the strings: every channel's name, every object's id, every
    object's class, joined by '"' (which no accepted string holds).
    """
    kk = 0
    rows3 = 0
    nbytes = 0
    for c in range(nc):
        if chans[c, _C_HAS_EGO] != 1:
            return _refused(_REFUSE)
        k = chans[c, _C_OBJ_N]
        o0 = chans[c, _C_OBJ]
        pts = objs[o0, _O_PRED_N] if k else 0
        for i in range(o0, o0 + k):
            # the common shape: id, x, y, a box and a prediction list of one length
            if (
                objs[i, _O_ID] < 0
                or objs[i, 0] < 0
                or objs[i, 1] < 0
                or objs[i, 5] < 0
                or objs[i, 6] < 0
                or objs[i, _O_PRED] < 0
                or objs[i, _O_PRED_N] != pts
            ):
                return _refused(_REFUSE)
            nbytes += objs[i, _O_ID_END] - objs[i, _O_ID] + 1
            if objs[i, _O_CLS] >= 0:
                nbytes += objs[i, _O_CLS_END] - objs[i, _O_CLS] + 1
            else:
                nbytes += 8  # 'unknown'
        nbytes += chans[c, _C_NAME_END] - chans[c, _C_NAME] + 1
        kk += k
        rows3 += chans[c, _C_PLAN_N] + k * pts
    nbytes = max(nbytes - 1, 0)  # no separator after the last string
    hlen = _H_FIXED + 3 * ns + _CH_COLS * nc
    o1 = hlen
    oy = o1 + 1 + 7 * nc
    o2 = oy + kk
    o4 = o2 + 6 * kk
    o3 = o4 + 8 * (nc + kk)
    end = o3 + 3 * rows3
    out = np.empty(end + (nbytes + 7) // 8)
    if not _fill(vals, t_index, chans, nc, objs, out, o1, oy, o2, o4, o3, kk):
        return _refused(_REFUSE)
    head = out.view(np.int64)
    head[_H_STATUS] = _OK
    head[_H_LEN] = hlen
    head[_H_NC] = nc
    head[_H_K] = kk
    head[_H_NS] = ns
    head[_H_NBYTES] = nbytes
    head[_H_R1] = o1
    head[_H_YAW] = oy
    head[_H_R2] = o2
    head[_H_R4] = o4
    head[_H_R3] = o3
    head[_H_ROWS3] = rows3
    head[_H_STR] = 8 * end
    for s in range(ns):
        for j in range(3):
            head[_H_FIXED + 3 * s + j] = spans[s, j]
    h = _H_FIXED + 3 * ns
    row3 = 0
    first = 0
    for c in range(nc):
        k = chans[c, _C_OBJ_N]
        pts = objs[chans[c, _C_OBJ], _O_PRED_N] if k else 0
        head[h + _CH_PLAN] = row3
        head[h + _CH_N] = chans[c, _C_PLAN_N]
        head[h + _CH_OBJ] = first
        head[h + _CH_K] = k
        head[h + _CH_P] = pts
        head[h + _CH_PRED] = row3 + chans[c, _C_PLAN_N]
        row3 += chans[c, _C_PLAN_N] + k * pts
        first += k
        h += _CH_COLS
    # the strings: names, then every id, then every class, each followed by '"' (the last
    # separator falls beyond nbytes and is not read)
    text = out.view(np.uint8)
    at = 8 * end
    stop = at + nbytes
    for c in range(nc):
        at = _put_bytes(text, at, buf, chans[c, _C_NAME], chans[c, _C_NAME_END])
        if at < stop:
            text[at] = 34
            at += 1
    for c in range(nc):
        o0 = chans[c, _C_OBJ]
        for row in range(o0, o0 + chans[c, _C_OBJ_N]):
            at = _put_bytes(text, at, buf, objs[row, _O_ID], objs[row, _O_ID_END])
            if at < stop:
                text[at] = 34
                at += 1
    for c in range(nc):
        o0 = chans[c, _C_OBJ]
        for row in range(o0, o0 + chans[c, _C_OBJ_N]):
            if objs[row, _O_CLS] >= 0:
                at = _put_bytes(text, at, buf, objs[row, _O_CLS], objs[row, _O_CLS_END])
            else:
                at = _put_bytes(text, at, _UNKNOWN, 0, 7)
            if at < stop:
                text[at] = 34
                at += 1
    return _OK_I, hlen, out


@_entry
def _parse(buf, n):  # pragma: no cover - compiled
    """Scan, then build when no number was left to orjson: (status, header length, out)."""
    status, vals, t_index, chans, nc, objs, _, _, _, spans, ns = _scan(_data_pointer(buf), n)
    if status != _OK:
        return _refused(status)
    return _build(buf, vals, t_index, chans, nc, objs, spans, ns)


@_entry
def _scan_tables(buf, n):  # pragma: no cover - compiled
    """The scan's tables, for a line with numbers left to orjson (`fast_frame` parses them and
    builds)."""
    status, vals, t_index, chans, nc, objs, _, hard, nh, spans, ns = _scan(_data_pointer(buf), n)
    return status, vals, t_index, chans, nc, objs, hard[:nh], spans, ns


#: pred_len and convex arrays by (objects, prediction points): copied for each frame (a copy
#: is several times cheaper than np.full/np.ones; each frame owns its arrays).
_TEMPLATES: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}


def _templates(k: int, pts: int) -> tuple[np.ndarray, np.ndarray]:
    """`pred_len` and `convex` for k box objects with predictions of `pts` points."""
    pair = _TEMPLATES.get((k, pts))
    if pair is None:
        if len(_TEMPLATES) > 4096:  # a bound for streams of every size and length
            _TEMPLATES.clear()
        pair = _TEMPLATES[(k, pts)] = (
            np.full(k, pts, dtype=np.int64),
            np.ones(k, dtype=np.bool_) if k else np.zeros(0, dtype=bool),
        )
    return pair


def _extras(raw: bytes, spans: list[int]) -> dict[str, Any] | None:
    """The values the scan left to orjson (unknown keys, `signals`, `odd`, `world`), by name;
    None when one is not valid JSON (the careful route names it)."""
    extras: dict[str, Any] = {}
    for s in range(0, len(spans), 3):
        kind, start, end = spans[s : s + 3]
        try:
            value = orjson.loads(raw[start:end])
        except orjson.JSONDecodeError:
            return None
        if kind:
            extras[SPAN_NAMES[kind]] = value
    return extras


#: The span kind of `signals` (SPAN_NAMES).
_SIGNALS = SPAN_NAMES.index("signals")


def _signals_only(
    raw: bytes, start: int, end: int
) -> tuple[dict[str, float | None], None, None] | None:
    """`_checked_extras(_extras(...))` for a line whose only span is `signals` (the common
    frame), without the dict of extras between them."""
    try:
        signals = orjson.loads(raw[start:end])
    except orjson.JSONDecodeError:
        return None
    if _decoded(signals):
        return signals, None, None
    return _checked_extras({"signals": signals})


def _decoded(signals: Any) -> TypeGuard[dict[str, float | None]]:
    """Whether `signals` is a dict of floats or nulls (what orjson gives for JSON numbers with
    a fraction or an exponent: never infinite), which `frame_extras` would copy unchanged."""
    if type(signals) is not dict:
        return False
    return all(value is None or type(value) is float for value in signals.values())


def _checked_extras(
    extras: dict[str, Any],
) -> tuple[dict[str, float | None], Any, Any] | None:
    """`parse.frame_extras(extras)`, or None for a defect. A frame with only `signals` whose
    values are all floats or null (what orjson gives for JSON numbers with a fraction or an
    exponent: never infinite) is taken as decoded: frame_extras would copy it unchanged."""
    if len(extras) == 1:
        signals = extras.get("signals")
        if _decoded(signals):
            return signals, None, None
    elif not extras:
        return {}, None, None
    try:
        return frame_extras(extras)
    except FrameDefect:
        return None


def fast_frame(
    text: str | bytes, known_channels: Iterable[str] | None = None, line: int = 0
) -> Frame | None:
    """The Frame `parse_frame(decode(text), known_channels, line)` gives, when the line has
    the common shape and nothing wrong; None otherwise (the caller then takes the careful
    route, which names the defect). Never raises a FrameDefect of its own. `text` may be the
    line's bytes (the reader's; a line that is not ASCII is left to the careful route)."""
    if orjson is None or not text.isascii():
        return None
    raw = text.encode("ascii") if isinstance(text, str) else text
    buf = np.frombuffer(raw + b"\0", np.uint8)
    status, hlen, out = _parse(buf, len(raw))
    if status == _HARD:
        status, hlen, out = _with_hard_numbers(buf, raw)
    if status != _OK:
        return None
    # Python values through memoryviews of the buffer: a numpy view per use costs more (each
    # numpy object a frame makes is a fifth of a microsecond; the channels need ten each)
    words = memoryview(out)
    head = words.cast("B").cast("q")[:hlen].tolist()
    nc, kk, ns, nbytes, o1, oy, o2, o4, o3, rows3, sb = head[_H_NC:_H_FIXED]
    if ns == 1 and head[_H_FIXED] == _SIGNALS:  # only `signals`: the common frame
        checked = _signals_only(raw, head[_H_FIXED + 1], head[_H_FIXED + 2])
    elif ns:
        extras = _extras(raw, head[_H_FIXED : _H_FIXED + 3 * ns])
        checked = None if extras is None else _checked_extras(extras)
    else:
        checked = {}, None, None
    if checked is None:
        return None
    signals, odd, world = checked
    # the strings straight from the buffer's bytes (no copy to a bytes object first)
    items = str(words.cast("B")[sb : sb + nbytes], "ascii").split('"')
    names = items[:nc]
    if len(set(names)) != nc:
        return None
    if known_channels is not None:
        known = (
            known_channels if isinstance(known_channels, (set, frozenset)) else set(known_channels)
        )
        if not known.issuperset(names):
            return None
    r1 = words[o1 : o1 + 1 + 7 * nc].tolist()
    rows2 = out[o2 : o2 + 6 * kk].reshape(3 * kk, 2)
    boxes = out[o4 : o4 + 8 * (nc + kk)].reshape(nc + kk, 4, 2)
    rows3_ = out[o3 : o3 + 3 * rows3].reshape(rows3, 3)
    channels: dict[str, ChannelState] = {}
    h = _H_FIXED + 3 * ns
    for c in range(nc):
        plan_row, npl, first, k, pts, pred_row = head[h : h + _CH_COLS]
        h += _CH_COLS
        e = 1 + 7 * c
        ego = Ego(
            r1[e],
            r1[e + 1],
            r1[e + 2],
            r1[e + 3],
            r1[e + 4],
            boxes[c],
            True,
            (r1[e + 5], r1[e + 6]),
        )
        end = first + k
        if k:
            ids = items[nc + first : nc + end]
            if k > 1 and len(set(ids)) != k:  # (one id is never a duplicate)
                return None  # duplicate-id: the careful route words it
        else:
            ids = []
        pred_len, convex = _templates(k, pts)
        objects = Objects(
            ids,
            items[nc + kk + first : nc + kk + end],
            rows2[first:end],
            out[oy + first : oy + end],
            rows2[kk + first : kk + end],
            boxes[nc + first : nc + end],
            rows3_[pred_row : pred_row + k * pts].reshape(k, pts, 3),
            pred_len.copy(),
            convex.copy(),
            rows2[2 * kk + first : 2 * kk + end],
        )
        channels[names[c]] = ChannelState(ego, rows3_[plan_row : plan_row + npl], objects)
    return Frame(r1[0], channels, signals, line, odd, world)


def _with_hard_numbers(buf: np.ndarray, raw: bytes) -> tuple[int, int, np.ndarray]:
    """`_parse` for a line with numbers the scan left to orjson: parse those, then build."""
    status, vals, t_index, chans, nc, objs, hard, spans, ns = _scan_tables(buf, len(raw))
    if status != _HARD:  # pragma: no cover - _parse said so
        return _FALLBACK, 0, np.empty(0)
    for index, start, end in hard.tolist():
        try:
            value = orjson.loads(raw[start:end])
        except orjson.JSONDecodeError:
            return _FALLBACK, 0, np.empty(0)  # beyond a double (1e400): the careful route
        vals[index] = value
    return _build(buf, vals, t_index, chans, nc, objs, spans, ns)  # type: ignore[no-any-return]
