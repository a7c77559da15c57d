#!/usr/bin/python3
"""Follows one stream's results with Python's kata.Subscriber over NATS, for test_nats's server
kills: given the cluster's servers as one comma-separated list (the form docs/deploy.md shows),
prints a line per result as it arrives, "<CLOCK_MONOTONIC ns> <frame_sequence> <owner> <epoch>",
flushed at once, plus "connected <url>" whenever the server it reads from changes. Runs until
SIGTERM or until nothing arrives for 20 s (exit 1).
Arguments: SERVERS STREAM_ID. KATA_LIBRARY and PYTHONPATH as for the bindings' tests."""
import signal, sys, time

import kata

servers, stream = sys.argv[1], int(sys.argv[2])
running = True


def stop(*_):
    global running
    running = False


signal.signal(signal.SIGTERM, stop)
with kata.Subscriber(servers, stream=stream) as sub:
    url = None
    last = time.monotonic()
    print("subscribed", flush=True)
    while running:
        m = sub.receive(timeout=0.5)
        if m is None:
            if time.monotonic() - last > 20:
                print("nothing for 20 s", flush=True)
                sys.exit(1)
            continue
        last = time.monotonic()
        if sub.nats_server != url:
            url = sub.nats_server
            print("connected", url, flush=True)
        print(time.monotonic_ns(), m.frame_sequence, m.owner, m.epoch, flush=True)
