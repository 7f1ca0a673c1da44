"""The compiled reader's number parser (`monitor.fastparse._number`) against orjson, value for
value: a JSON number must become the double orjson makes of it (the careful route's value,
`np.array(..., dtype=float)` of orjson's float or int), bit for bit, or be handed back to
orjson (state 2), or be refused (state 0) when it is not the common shape."""

from __future__ import annotations

import json
import random
import struct

import numpy as np
import orjson
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.fastparse import _eisel_lemire, _number


def parse(token: str) -> tuple[int, float, int, bool]:
    """(end, value, state, is_int) of the number at the start of `token` (0-terminated)."""
    buf = np.frombuffer(token.encode("ascii") + b"\0", np.uint8)
    end, value, state, is_int = _number(buf, 0)
    return int(end), float(value), int(state), bool(is_int)


def bits(x: float) -> int:
    return struct.unpack("<q", struct.pack("<d", x))[0]


def expected(token: str) -> float:
    """What the careful route holds: orjson's value as a float array element."""
    return float(np.array([orjson.loads(token)], dtype=float)[0])


def check(token: str) -> int:
    """Assert the parser agrees with orjson on `token`; return its state."""
    end, value, state, is_int = parse(token)
    assert end == len(token), token
    try:
        orjson.loads(token)
    except orjson.JSONDecodeError:  # beyond a double (2e308): never a parsed value here
        assert state == 2, token
        return state
    assert state in (1, 2), token
    if state == 1:
        assert bits(value) == bits(expected(token)), (token, value, expected(token))
    assert is_int == isinstance(orjson.loads(token), int), token
    return state


def random_double(rng: random.Random) -> float:
    while True:
        x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
        if np.isfinite(x):
            return x


def test_random_doubles_in_every_written_form():
    """repr (shortest round trip, 17 digits at most), json.dumps, orjson.dumps, %.Ng forms:
    every one parsed (state 1) is the same double; few are handed back."""
    rng = random.Random(36)
    handed_back = 0
    total = 0
    for _ in range(20000):
        x = random_double(rng) if rng.random() < 0.5 else rng.uniform(-1e4, 1e4)
        for token in {
            repr(x),
            json.dumps(x),
            orjson.dumps(x).decode(),
            f"{x:.{rng.randint(1, 17)}g}",
            f"{x:.{rng.randint(0, 8)}f}" if abs(x) < 1e15 else repr(x),
        }:
            token = token.replace("inf", "").strip() or "0"
            total += 1
            handed_back += check(token) == 2
    # only subnormals, overflows and > 18 significant digits are handed back
    assert handed_back < total * 0.02


def test_rounded_values_of_a_drive_take_the_exact_path():
    rng = random.Random(7)
    for _ in range(20000):
        x = round(rng.uniform(-1e6, 1e6), rng.randint(0, 6))
        assert check(repr(x)) == 1


@given(
    digits=st.text(alphabet="0123456789", min_size=1, max_size=22),
    point=st.integers(min_value=0, max_value=22),
    exponent=st.one_of(st.none(), st.integers(min_value=-340, max_value=320)),
    neg=st.booleans(),
    upper=st.booleans(),
    sign=st.sampled_from(["", "+", "-"]),
)
@settings(max_examples=3000, deadline=None)
def test_decimal_strings(digits, point, exponent, neg, upper, sign):
    """Any valid JSON number: integer and fraction digits, exponents of either sign, leading
    zeros of the fraction, 19+ digits (handed back), huge and tiny magnitudes."""
    digits = digits.lstrip("0") or "0"
    point = min(point, len(digits))
    token = digits[:point] + "." + digits[point:] if 0 < point < len(digits) else digits
    if exponent is not None:
        token += ("E" if upper else "e") + sign + str(abs(exponent))
    if neg:
        token = "-" + token
    try:
        orjson.loads(token)
    except orjson.JSONDecodeError:  # beyond a double: must not be parsed as a value
        assert parse(token)[2] != 1
        return
    if "." not in token and "e" not in token.lower() and len(digits) > 18:
        assert parse(token)[2] == 0  # a 19+ digit integer: orjson's own type rules, refused
        return
    check(token)


@pytest.mark.parametrize(
    ("token", "value"),
    [
        ("0", 0.0),
        ("-0", 0.0),  # Python's int 0: a positive zero
        ("-0.0", -0.0),
        ("-0e5", -0.0),
        ("0e999", 0.0),
        ("1e300", 1e300),
        ("-1E-300", -1e-300),
        ("123456789012345678", 123456789012345678.0),
        ("9007199254740993", 9007199254740992.0),  # an int beyond 2**53: rounded to even
        ("0.30000000000000004", 0.30000000000000004),
        ("0.012345678901234568", 0.012345678901234568),  # 17 significant digits
        ("2.2250738585072014e-308", 2.2250738585072014e-308),
        ("1.7976931348623157e308", 1.7976931348623157e308),
        ("397.7992", 397.7992),
    ],
)
def test_known_values(token, value):
    end, got, state, _ = parse(token)
    assert end == len(token) and state == 1
    assert bits(got) == bits(value) == bits(expected(token))


@pytest.mark.parametrize(
    "token",
    ["1e400", "-1e400", "4.9e-324", "1e-400", "1234567890123456789.5", "0.1234567890123456789"],
)
def test_what_is_handed_back_to_orjson(token):
    """Overflow, subnormals and underflow, more than 18 significant digits: orjson decides."""
    assert parse(token)[2] == 2


@pytest.mark.parametrize(
    "token",
    ["-", "+1", ".5", "1.", "1e", "1e+", "-a", "", "NaN", "Infinity", "1234567890123456789"],
)
def test_not_numbers_or_not_the_common_shape(token):
    """Not JSON numbers (the caller's delimiter check catches '01', '1.5.3'), and integers
    beyond 18 digits (orjson reads them by its own type rules): refused."""
    assert parse(token)[2] == 0


def test_the_number_ends_where_json_says():
    assert parse("01")[0] == 1  # the caller then sees '1' where a delimiter belongs
    assert parse("1.5.3")[0] == 3
    assert parse("2]")[0] == 1


@given(
    w=st.integers(min_value=1, max_value=10**18 - 1),
    q=st.integers(min_value=-342, max_value=308),
)
@settings(max_examples=5000, deadline=None)
def test_eisel_lemire_against_python(w, q):
    """The 128-bit algorithm on its own: where it answers, the correctly rounded double of
    w * 10**q (Python's float of the decimal string)."""
    ok, value = _eisel_lemire(np.uint64(w), q)
    if ok:
        assert bits(value) == bits(float(f"{w}e{q}"))
