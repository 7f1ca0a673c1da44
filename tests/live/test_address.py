"""`--serve [HOST:]PORT`: loopback by default, any other address only when asked."""

from __future__ import annotations

import pytest

from casewatch.live.address import AddressError, ServeAddress, parse_address


@pytest.mark.parametrize(
    ("text", "host", "port"),
    [
        ("8765", "127.0.0.1", 8765),
        ("0", "127.0.0.1", 0),
        (":9000", "127.0.0.1", 9000),
        ("localhost:80", "localhost", 80),
        ("127.0.0.2:8080", "127.0.0.2", 8080),
        ("[::1]:8080", "::1", 8080),
    ],
)
def test_loopback_addresses_are_accepted(text, host, port):
    assert parse_address(text) == ServeAddress(host, port)


@pytest.mark.parametrize("text", ["0.0.0.0:8080", "192.168.1.4:80", "[::]:80", "example.org:80"])
def test_other_addresses_need_the_explicit_flag(text):
    with pytest.raises(AddressError, match="--serve-public"):
        parse_address(text)
    assert not parse_address(text, public=True).loopback


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("http", "expected \\[HOST:\\]PORT"),
        ("70000", "not between 0 and 65535"),
        ("::1:80", "in brackets"),
    ],
)
def test_malformed_addresses_say_what_was_expected(text, message):
    with pytest.raises(AddressError, match=message):
        parse_address(text)


def test_urls_bracket_ipv6_hosts():
    assert ServeAddress("::1", 0).url(4321) == "http://[::1]:4321/"
    assert ServeAddress("127.0.0.1", 8765).url() == "http://127.0.0.1:8765/"
