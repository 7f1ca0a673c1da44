"""`--serve [HOST:]PORT`: where the live page listens, loopback unless asked otherwise.

The page shows a safety case's live verdicts and the stream's metadata; nothing authenticates
its readers, so it binds the loopback interface by default and refuses any other address
unless the caller passes `--serve-public` (then it is the caller's network that protects it).
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass

from casewatch.errors import CasewatchError

DEFAULT_HOST = "127.0.0.1"
LOOPBACK_NAMES = frozenset({"localhost"})


class AddressError(CasewatchError, ValueError):
    """A `--serve` address that cannot be used (malformed, or not loopback without the flag)."""


@dataclass(frozen=True)
class ServeAddress:
    host: str
    port: int

    @property
    def loopback(self) -> bool:
        if self.host in LOOPBACK_NAMES:
            return True
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return False

    def url(self, port: int | None = None) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port if port is None else port}/"


def parse_address(text: str, public: bool = False) -> ServeAddress:
    """`PORT`, `HOST:PORT` or `[IPV6]:PORT`; a host that is not loopback needs `public`."""
    text = text.strip()
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = DEFAULT_HOST, text
    elif host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    elif ":" in host:
        raise AddressError(f"--serve {text!r}: write an IPv6 address in brackets, [::1]:8080")
    if not host:
        host = DEFAULT_HOST
    try:
        port = int(port_text)
    except ValueError:
        raise AddressError(f"--serve {text!r}: expected [HOST:]PORT, e.g. 8765") from None
    if not 0 <= port <= 65535:
        raise AddressError(f"--serve {text!r}: port {port} is not between 0 and 65535")
    address = ServeAddress(host, port)
    if not address.loopback and not public:
        raise AddressError(
            f"--serve {text!r}: {host} is not a loopback address; the live page has no "
            "login, so casewatch serves it on this machine only (127.0.0.1, ::1, localhost) "
            "unless you add --serve-public"
        )
    return address
