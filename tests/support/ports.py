"""Free TCP ports for the tests' servers, below Linux's ephemeral range (32768-60999 by default).

A port the kernel hands out for bind(port 0) is in the ephemeral range, where any outgoing
connection on the machine (the other tests' ZeroMQ and NATS clients make hundreds) can take it
between our check and the server's bind: "address already in use" in a test that ran beside them.
Below that range only another listener can take a port; the NATS harness picks the same way
(tests/transport/nats/nats_cluster.cpp). Each process draws from its own random sequence and never
returns a port twice."""
import os
import random
import socket
import time

_random = random.Random(os.getpid() * 2654435761 ^ time.monotonic_ns())
_given = set()


def free_port():
    """A TCP port on 127.0.0.1 that nothing listened on a moment ago (20000-31999)."""
    for _ in range(500):
        port = _random.randrange(20000, 32000)
        if port in _given:
            continue
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
        _given.add(port)
        return port
    raise RuntimeError("no free port in 20000-31999 after 500 tries")
