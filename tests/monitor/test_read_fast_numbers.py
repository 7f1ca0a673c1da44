"""The number parser as the scanner runs it, through a pointer to the line
(`fastparse._data_pointer`), against the same parser on the array (what
test_fast_parse_numbers.py holds to orjson bit for bit) and against orjson: the same end,
value (bit for bit), state and integer flag, on random tokens in every written form."""

from __future__ import annotations

import json
import struct

import numpy as np
import orjson
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.fastparse import _data_pointer, _number
from casewatch.monitor.jit import kernel


@kernel
def _number_via_pointer(buf, p):  # pragma: no cover - compiled
    return _number(_data_pointer(buf), p)


def bits(x: float) -> int:
    return struct.unpack("<q", struct.pack("<d", x))[0]


def both(token: str) -> tuple[int, int, int, bool]:
    buf = np.frombuffer(token.encode("ascii") + b"\0", np.uint8)
    end, value, state, is_int = _number(buf, 0)
    pend, pvalue, pstate, pis_int = _number_via_pointer(buf, 0)
    assert (int(pend), bits(pvalue), int(pstate), bool(pis_int)) == (
        int(end),
        bits(value),
        int(state),
        bool(is_int),
    ), token
    return int(end), bits(value), int(state), bool(is_int)


def test_hand_picked_tokens_agree_with_orjson() -> None:
    for token in ["0", "-0", "-0.0", "397.7992", "-4.8319", "0.0417", "1e5", "12345678901234567"]:
        end, value, state, is_int = both(token)
        assert end == len(token) and state == 1
        assert value == bits(float(np.array([orjson.loads(token)], dtype=float)[0]))
        assert is_int == isinstance(orjson.loads(token), int)


@settings(max_examples=3000, deadline=None)
@given(
    st.one_of(
        st.floats(allow_nan=False, allow_infinity=False).map(repr),
        st.floats(allow_nan=False, allow_infinity=False).map(json.dumps),
        st.integers(min_value=-(10**25), max_value=10**25).map(str),
        st.from_regex(
            r"-?(0|[1-9][0-9]{0,20})(\.[0-9]{1,20})?([eE][-+]?[0-9]{1,3})?", fullmatch=True
        ),
        st.text(alphabet="-0123456789.eE+", min_size=1, max_size=12),
    )
)
def test_the_pointer_route_reads_every_token_as_the_array_route(token: str) -> None:
    both(token.replace("inf", "1").replace("nan", "1"))
