#!/usr/bin/python3
"""Python's kata.Subscriber reads either transport: kata send feeds 4 streams x
60 frames of 05_18 to one kata serve over ZeroMQ and then to a kata serve shard over NATS (one
nats-server with JetStream and the partition mapping, started here on its own port and
directory); kata.Subscriber("tcp://...") and kata.Subscriber("nats://...") each read every result
once, in order, and the two runs' results are equal value for value (the same pipeline on the
same frames). Over NATS each result names its shard and a lease epoch, nothing is stale or refused,
and the skeleton definitions on the results' subjects are counted as skipped.
samples/c_subscriber.c (built with libnats) reads one stream over NATS in the same run: the same
frames and scores as Python's, each line naming the shard and its epoch.
Arguments: the kata CLI, the source directory, the C sample subscriber. ctest sets KATA_LIBRARY
and PYTHONPATH."""
import ctypes, json, os, re, shutil, signal, subprocess, sys, tempfile, time

kata, source, c_subscriber = sys.argv[1:4]
sys.path.insert(0, os.path.join(source, "tests", "support"))
from ports import free_port  # noqa: E402
import kata as kpy  # noqa: E402

STREAMS, FRAMES, FIRST_ID = 4, 60, 900
clip = os.path.join(source, "data", "cmu", "05_18.bvh")
scoring = '[runtime]\nworkers = 1\n[scoring]\nmodel = "%s"\nteacher = "%s"\nghost = true\n' % (
    os.path.join(source, "models", "default.kata"), clip)
send_args = ["--bvh", clip, "--streams", str(STREAMS), "--stream-id", str(FIRST_ID), "--frames", str(FRAMES),
             "--warmup", "0.5"]


def read_all(sub, deadline_s=60.0):
    """Every result until STREAMS x FRAMES came, or nothing new for 5 s."""
    got = {}
    end = time.monotonic() + deadline_s
    while sum(len(v) for v in got.values()) < STREAMS * FRAMES and time.monotonic() < end:
        m = sub.receive(timeout=5.0)
        if m is None:
            break
        got.setdefault(m.stream_id, []).append(m)
    return got


def stop(p, log):
    p.send_signal(signal.SIGINT)
    try:
        p.wait(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
    assert p.returncode == 0, open(log).read()


def fingerprint(m):
    return (m.frame_sequence, m.frame_index, m.scored, m.score, m.distance, m.matched_teacher_frame, m.part_scores,
            m.part_to_fix, m.cue, None if m.ghost is None else m.ghost.tobytes())


def check(got, path):
    assert sorted(got) == list(range(FIRST_ID, FIRST_ID + STREAMS)), (path, sorted(got))
    for sid, results in got.items():
        assert len(results) == FRAMES, (path, sid, len(results))
        assert [m.result_sequence for m in results] == list(range(results[0].result_sequence,
                                                                  results[0].result_sequence + FRAMES)), (path, sid)
        assert [m.frame_sequence for m in results] == sorted(m.frame_sequence for m in results), (path, sid)
        assert sum(m.scored for m in results) > FRAMES // 2, (path, sid, "scored", sum(m.scored for m in results))


nats_server = shutil.which("nats-server") or next((p for p in ("/usr/sbin/nats-server", "/usr/bin/nats-server")
                                                   if os.access(p, os.X_OK)), None)
assert nats_server, "nats-server not found (Debian package nats-server)"

with tempfile.TemporaryDirectory(prefix="kata_py_nats_") as tmp:
    # 1. ZeroMQ: one kata serve, Subscriber on its publish endpoint.
    port_in, port_out = free_port(), free_port()
    config = os.path.join(tmp, "zmq.toml")
    open(config, "w").write('[ingest]\nendpoints = ["bind:tcp://127.0.0.1:%d"]\nkind = "pull"\nmax_frame_age_ms = 0\n'
                            '[publish]\nendpoints = ["tcp://127.0.0.1:%d"]\n%s' % (port_in, port_out, scoring))
    log = os.path.join(tmp, "zmq.log")
    serve = subprocess.Popen([kata, "serve", "--config", config], stderr=open(log, "w"))
    try:
        with kpy.Subscriber("tcp://127.0.0.1:%d" % port_out) as sub:
            deadline = time.monotonic() + 20
            while "publishing on" not in open(log).read() and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.5)  # the SUB connection
            subprocess.run([kata, "send", "--endpoint", "tcp://127.0.0.1:%d" % port_in] + send_args, check=True,
                           timeout=60, stderr=subprocess.DEVNULL)
            over_zmq = read_all(sub)
            assert sub.refused == 0, sub.refused
            assert all(m.owner == "" and m.epoch == 0 for v in over_zmq.values() for m in v)
    finally:
        stop(serve, log)
    check(over_zmq, "zmq")

    # 2. NATS: one server (JetStream, the mapping kata serve's partitions need), one shard.
    port = free_port()
    conf = os.path.join(tmp, "nats.conf")
    open(conf, "w").write('server_name: py0\nlisten: 127.0.0.1:%d\njetstream { store_dir: "%s", max_memory_store: 64MB, '
                          'max_file_store: 0 }\nmappings { "kata.in.*": "kata.in.{{partition(64,1)}}.{{wildcard(1)}}" }\n'
                          % (port, os.path.join(tmp, "js")))
    url = "nats://127.0.0.1:%d" % port
    server_log = os.path.join(tmp, "nats.log")
    server = subprocess.Popen([nats_server, "-c", conf], stdout=subprocess.DEVNULL, stderr=open(server_log, "w"))
    shard = None
    try:
        deadline = time.monotonic() + 20
        while "Server is ready" not in open(server_log).read() and time.monotonic() < deadline:
            assert server.poll() is None, open(server_log).read()
            time.sleep(0.05)
        config = os.path.join(tmp, "nats.toml")
        open(config, "w").write('[transport]\nkind = "nats"\nservers = ["%s"]\nshard = "py-a"\nlease_replicas = 1\n'
                                '[ingest]\nmax_frame_age_ms = 0\n%s' % (url, scoring))
        log = os.path.join(tmp, "shard.log")
        shard = subprocess.Popen([kata, "serve", "--config", config], stderr=open(log, "w"))
        # The frames start once the shard holds every partition: the lease bucket (a JetStream
        # stream KV_kata_leases) then has a key per partition, read here with the same libnats.
        lib = kpy.messages._Nats.library()
        lib.natsConnection_ConnectTo.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_char_p]
        lib.natsConnection_RequestString.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_void_p,
                                                     ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int64]
        nc = ctypes.c_void_p()
        assert lib.natsConnection_ConnectTo(ctypes.byref(nc), url.encode()) == 0
        held = 0
        deadline = time.monotonic() + 30
        while held < 64 and time.monotonic() < deadline:
            assert shard.poll() is None, open(log).read()
            reply = ctypes.c_void_p()
            if lib.natsConnection_RequestString(ctypes.byref(reply), nc, b"$JS.API.STREAM.INFO.KV_kata_leases", b"",
                                                1000) == 0:
                info = json.loads(ctypes.string_at(lib.natsMsg_GetData(reply), lib.natsMsg_GetDataLength(reply)))
                lib.natsMsg_Destroy(reply)
                subjects = info.get("state", {}).get("num_subjects", 0)
                held = subjects - 1 if subjects else 0  # the partitions' keys and the shard's membership key
            if held < 64:
                time.sleep(0.1)
        lib.natsConnection_Destroy(nc)
        assert held >= 64, ("the shard never held the partitions", held, open(log).read())
        c_log = os.path.join(tmp, "c_subscriber.log")
        csub = subprocess.Popen([c_subscriber, url, str(FIRST_ID + 2), str(FRAMES)], stdout=subprocess.PIPE,
                                stderr=open(c_log, "w"), text=True)
        deadline = time.monotonic() + 20
        while "subscribed to" not in open(c_log).read() and time.monotonic() < deadline:
            assert csub.poll() is None, open(c_log).read()
            time.sleep(0.05)
        with kpy.Subscriber(url) as sub, kpy.Subscriber([url], stream=FIRST_ID + 1) as one:
            subprocess.run([kata, "send", "--transport", "nats", "--nats-server", url] + send_args, check=True,
                           timeout=60, stderr=subprocess.DEVNULL)
            over_nats = read_all(sub)
            assert sub.refused == 0 and sub.stale == 0 and sub.dropped == 0, (sub.refused, sub.stale, sub.dropped)
            assert sub.skipped >= STREAMS, ("every stream's definition on its results' subject", sub.skipped)
            only = []
            while len(only) < FRAMES:
                m = one.receive(timeout=5.0)
                if m is None:
                    break
                only.append(m)
            assert [m.stream_id for m in only] == [FIRST_ID + 1] * FRAMES, [m.stream_id for m in only][:5]
        c_lines = csub.communicate(timeout=60)[0].splitlines()
        assert csub.returncode == 0, (csub.returncode, open(c_log).read())
    finally:
        if shard is not None:
            stop(shard, log)
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=30)
    check(over_nats, "nats")
    for sid, results in over_nats.items():
        assert {m.owner for m in results} == {"py-a"}, (sid, {m.owner for m in results})
        assert len({m.epoch for m in results}) == 1 and results[0].epoch > 0, (sid, {m.epoch for m in results})
        assert [fingerprint(m) for m in results] == [fingerprint(m) for m in over_zmq[sid]], sid
    assert [fingerprint(m) for m in only] == [fingerprint(m) for m in over_nats[FIRST_ID + 1]]
    # The C sample: "stream S frame F: score X (...) ..., fix P (shard O, epoch E)", one line a result.
    pattern = re.compile(r"^stream (\d+) frame (\d+): score (-?[\d.]+) .* \(shard (\S+), epoch (\d+)\)$")
    parsed = [pattern.match(line) for line in c_lines]
    assert len(parsed) == FRAMES and all(parsed), c_lines[:3]
    mine = over_nats[FIRST_ID + 2]
    assert [(int(p.group(1)), int(p.group(2)), p.group(3), p.group(4), int(p.group(5))) for p in parsed] == \
        [(m.stream_id, m.frame_sequence, "%.1f" % (m.score if m.scored else 0.0), m.owner, m.epoch) for m in mine], \
        (c_lines[:3], [(m.frame_sequence, m.score) for m in mine[:3]])
print("python subscriber over ZeroMQ and NATS ok")
