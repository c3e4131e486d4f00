"""A Dask scheduler address, checked before anything is loaded or rendered:
Dask's own parsing of a bad one ends in a ValueError or TypeError
traceback, and only once the scene is loaded."""
import ipaddress

from raytrace.errors import OptionError

# Transports a scheduler can be reached over from another process.  inproc://
# names a scheduler inside one process, so never this command's.
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
EXAMPLE = "tcp://HOST:8786"


def check_scheduler_address(address):
    """``address`` ("tcp://host:8786", "host:8786", "tls://[::1]:8786") as
    it is, or an OptionError saying what is wrong with it."""
    if not isinstance(address, str):
        raise OptionError(f"scheduler address must be a string like {EXAMPLE}, got {address!r}")
    text = address.strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme not in SCHEMES:
        raise OptionError(f"scheduler address {address!r}: unknown transport {scheme + '://'!r} "
                          f"(use {', '.join(s + '://' for s in SCHEMES)})")
    if rest.startswith("["):                   # [IPv6]:port
        host, bracket, port = rest[1:].partition("]")
        if not bracket or not port.startswith(":"):
            raise OptionError(f"scheduler address {address!r}: expected [IPV6]:PORT, like "
                              "tcp://[::1]:8786")
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            raise OptionError(f"scheduler address {address!r}: {host!r} is not an IPv6 "
                              "address") from None
        port = port[1:]
    else:
        host, colon, port = rest.rpartition(":")
        if not colon:
            raise OptionError(f"scheduler address {address!r}: expected HOST:PORT, like {EXAMPLE}")
    if not host or any(c.isspace() or c in "/[]@?#" for c in host) or not host.isprintable():
        raise OptionError(f"scheduler address {address!r}: expected a host name or address "
                          f"before the port, like {EXAMPLE}")
    if not (port.isascii() and port.isdigit() and 1 <= int(port) <= 65535):
        raise OptionError(f"scheduler address {address!r}: the port must be a number from 1 to "
                          f"65535, got {port!r}")
    return text
