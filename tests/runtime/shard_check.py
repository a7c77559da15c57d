#!/usr/bin/python3
"""Shards behind ZeroMQ proxies, end to end on loopback ipc (docs/deploy.md):

  kata send --socket pub --streams 48 -> kata proxy (frames) -> 3 x kata serve ([shard] count 3)
  -> kata proxy (results) -> this script's SUB socket

1. reference: the same 48 streams through one `kata serve` (no shards, no proxy);
2. sharded: every result arrives, in order per stream, equal to the reference's (score, distance,
   matched teacher frame), and each stream's results came from the shard kata_shard_of names;
3. a shard SIGKILLed while frames flow and restarted: the other shards' streams have no sequence
   gap and equal the reference, the killed shard's streams resume (results after the restart),
   and the gaps this consumer counts equal the frames it did not receive;
4. both proxies SIGKILLed and restarted while frames flow: every stream resumes, skeleton
   definitions come again, the gaps are counted.
Every process is bounded (timeouts; killed in `finally`); paths are unique per run.
Usage: shard_check.py KATA_BINARY SOURCE_DIR PYTHON_DIR"""
import os, signal, subprocess, sys, tempfile, time

import zmq

kata, source, python_dir = sys.argv[1:4]
sys.path.insert(0, python_dir)
from kata.fb.Result import Result  # noqa: E402
sys.path.insert(0, os.path.join(source, "tests", "support"))
import accounting  # noqa: E402

STREAMS, SHARDS, FRAMES = 48, 3, 300
SPEED = 0.5  # the 120 Hz CMU clip at 60 Hz: 48 x 60 = 2880 frames/s into the proxy
# The reference is one process for all 48 streams (2880 frames/s at this speed): an ASan build on
# a loaded 2-core machine falls behind (at load 10-21 it dropped hundreds to thousands of frames,
# queue_full), so its worker queue holds every frame of the run and it may compute late.
REFERENCE_SPEED = 0.5
BVH = os.path.join(source, "data", "cmu", "07_01.bvh")


def shard_of(stream_id, count):
    """kata_shard_of (kata.h): FNV-1a 64 over the id's 8 bytes, least significant first, mod count."""
    if count <= 1:
        return 0
    h = 14695981039346656037
    for byte in range(8):
        h ^= (stream_id >> (8 * byte)) & 0xFF
        h = (h * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h % count


class Stage:
    def __init__(self, tmp):
        self.tmp, self.procs, self.logs = tmp, {}, {}

    def ep(self, name):
        return "ipc://%s/%s" % (self.tmp, name)

    def start(self, name, args):
        log = open(os.path.join(self.tmp, name + ".log"), "w")
        self.logs[name] = log.name
        self.procs[name] = subprocess.Popen([kata] + args, stdout=log, stderr=subprocess.STDOUT)

    def proxy(self, name, front, back):
        self.start(name, ["proxy", "--frontend", self.ep(front), "--backend", self.ep(back), "--status-interval", "0",
                          "--seconds", "120"])

    def serve(self, name, ingest, publish, shard=None, kind="sub", ingest_extra="", runtime_extra=""):
        config = os.path.join(self.tmp, name + ".toml")
        with open(config, "w") as f:
            f.write('[ingest]\nendpoints = ["%s"]\nkind = "%s"\n%s' % (ingest, kind, ingest_extra))
            f.write('[publish]\nendpoints = ["%s"]\nsend_hwm = 1000000\n' % publish)
            f.write('[runtime]\nworkers = 1\nskeleton_resend_seconds = 0.5\n%s' % runtime_extra)
            f.write('[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s/data/cmu/02_01.bvh"\nghost = false\n'
                    % (source, source))
            if shard is not None:
                f.write("[shard]\ncount = %d\nindex = %d\n" % (SHARDS, shard))
        self.start(name, ["serve", "--config", config, "--counters", self.counters(name)])

    def counters(self, name):
        """Where kata serve NAME writes its per-stream counters when it stops (accounting.py)."""
        return os.path.join(self.tmp, name + ".counters.json")

    def wait_ready(self, name, timeout=30):
        deadline = time.time() + timeout
        while time.time() < deadline:
            if "kata serve: ingest" in open(self.logs[name]).read():
                return
            assert self.procs[name].poll() is None, open(self.logs[name]).read()
            time.sleep(0.05)
        raise AssertionError("%s not ready: %s" % (name, open(self.logs[name]).read()))

    def kill(self, name, sig=signal.SIGKILL):
        p = self.procs.pop(name)
        p.send_signal(sig)
        p.wait(timeout=30)
        return p.returncode

    def stop_all(self):
        for name in list(self.procs):
            p = self.procs.pop(name)
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()


def send(stage, endpoint, socket, speed, warmup):
    return subprocess.Popen([kata, "send", "--bvh", BVH, "--endpoint", endpoint, "--socket", socket,
                             "--stream-id", "100", "--streams", str(STREAMS), "--frames", str(FRAMES),
                             "--speed", str(speed), "--warmup", str(warmup), "--definition-interval", "0.25"],
                            stdout=subprocess.DEVNULL, stderr=open(os.path.join(stage.tmp, "send.log"), "a"))


class Consumer:
    """Every result by stream: frame_sequence -> (score, distance, matched frame), arrival order kept."""

    def __init__(self, endpoint):
        self.sub = zmq.Context.instance().socket(zmq.SUB)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"")
        self.sub.setsockopt(zmq.RCVHWM, 1000000)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.connect(endpoint)
        self.results, self.order, self.definitions = {}, {}, {}
        self.received = 0

    def pump(self, seconds, until=None):
        end = time.time() + seconds
        while time.time() < end:
            if until and until():
                return True
            if not self.sub.poll(50):
                continue
            while True:
                try:
                    m = self.sub.recv(zmq.NOBLOCK)
                except zmq.Again:
                    break
                body = m[16:]
                kind = body[4:8]
                stream = int(m[:16], 16)
                if kind == b"KSKL":
                    self.definitions[stream] = self.definitions.get(stream, 0) + 1
                elif kind == b"KRES":
                    r = Result.GetRootAs(body, 0)
                    seq = r.FrameSequence()
                    self.results.setdefault(stream, {})[seq] = (r.Score(), r.Distance(), r.MatchedTeacherFrame())
                    self.order.setdefault(stream, []).append(seq)
                    self.received += 1
        return until() if until else False

    def drain_until_quiet(self, sender, limit=90):
        deadline = time.time() + limit
        while sender.poll() is None and time.time() < deadline:
            self.pump(0.2)
        assert sender.returncode == 0, "kata send failed"
        last = self.received
        while time.time() < deadline:  # everything in flight, then 1.5 s of silence
            self.pump(1.5)
            if self.received == last:
                return
            last = self.received

    def gaps(self, stream):
        seqs = self.order.get(stream, [])
        assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs), "stream %d: results out of order" % stream
        return FRAMES - len(seqs)


ids = list(range(100, 100 + STREAMS))
owner = {i: shard_of(i, SHARDS) for i in ids}
assert sorted(set(owner.values())) == list(range(SHARDS)), "48 ids must cover every shard"
killed = 1
killed_ids = [i for i in ids if owner[i] == killed]

with tempfile.TemporaryDirectory(prefix="kata_shard_%d_" % os.getpid()) as tmp:
    # 1. reference: one process, frames pushed straight in (PUSH/PULL: nothing dropped; no frame
    # judged stale and room for all in its queue, as a reference must keep every one whatever the load).
    stage = Stage(tmp)
    try:
        stage.serve("single", "bind:" + stage.ep("single_in"), stage.ep("single_out"), kind="pull",
                    ingest_extra="max_frame_age_ms = 0\n", runtime_extra="frame_queue_capacity = 16384\n")
        stage.wait_ready("single")
        ref = Consumer(stage.ep("single_out"))
        ref.pump(0.5)
        sender = send(stage, stage.ep("single_in"), "push", REFERENCE_SPEED, 1.0)
        ref.drain_until_quiet(sender)
    finally:
        stage.stop_all()
    # Every frame sent is a result received or a counted drop (named by stream and stage), and
    # the reference counts none.
    accounting.check({i: FRAMES for i in ids}, {i: len(ref.order.get(i, [])) for i in ids},
                     accounting.load(stage.counters("single")), where="reference")
    for i in ids:
        assert ref.gaps(i) == 0, "reference: stream %d got %d of %d" % (i, len(ref.order.get(i, [])), FRAMES)
    print("reference: %d results, %d streams" % (ref.received, STREAMS))

    def sharded_stage(tag):
        s = Stage(os.path.join(tmp, tag))
        os.mkdir(s.tmp)
        s.proxy("frames_proxy", "fin", "fout")
        s.proxy("results_proxy", "rin", "rout")
        consumer = Consumer(s.ep("rout"))
        for k in range(SHARDS):
            s.serve("shard%d" % k, s.ep("fout"), "connect:" + s.ep("rin"), shard=k)
        for k in range(SHARDS):
            s.wait_ready("shard%d" % k)
        return s, consumer

    def same_as_reference(consumer, stream):
        for seq, value in consumer.results.get(stream, {}).items():
            assert value == ref.results[stream][seq], "stream %d frame %d: %s != %s" % (
                stream, seq, value, ref.results[stream][seq])

    # 2. three shards behind the proxies: everything arrives, equal to the reference.
    stage, consumer = sharded_stage("sharded")
    try:
        sender = send(stage, stage.ep("fin"), "pub", SPEED, 2.0)
        assert consumer.pump(30, lambda: len(consumer.definitions) == STREAMS), \
            "definitions of %d streams seen during the warm-up" % len(consumer.definitions)
        consumer.drain_until_quiet(sender)
    finally:
        stage.stop_all()
    for k in range(SHARDS):
        log = open(stage.logs["shard%d" % k]).read()
        mine = sum(1 for i in ids if owner[i] == k)
        accounting.check({i: FRAMES for i in ids if owner[i] == k},
                         {i: len(consumer.order.get(i, [])) for i in ids}, accounting.load(stage.counters("shard%d" % k)),
                         where="sharded, shard %d" % k)
        assert ("%d results published" % (mine * FRAMES)) in log, log[-400:]
    for i in ids:
        assert consumer.gaps(i) == 0, "sharded: stream %d got %d of %d" % (i, len(consumer.order.get(i, [])), FRAMES)
        same_as_reference(consumer, i)
    print("sharded: %d results from %d shards, equal to the reference" % (consumer.received, SHARDS))

    # 3. SIGKILL one shard while frames flow, restart it.
    stage, consumer = sharded_stage("killed")
    try:
        # Half the speed: the restarted shard (an ASan build on a loaded machine took seconds to
        # start) must be up while frames still flow.
        sender = send(stage, stage.ep("fin"), "pub", SPEED / 2, 2.0)
        assert consumer.pump(30, lambda: len(consumer.definitions) == STREAMS)
        # Frames flow for ~3 s (90 of 300 per stream), then the shard dies.
        assert consumer.pump(30, lambda: all(len(consumer.order.get(i, [])) >= 90 for i in killed_ids))
        assert stage.kill("shard%d" % killed) == -signal.SIGKILL
        consumer.pump(1.0)
        stage.serve("shard%d" % killed, stage.ep("fout"), "connect:" + stage.ep("rin"), shard=killed)
        stage.wait_ready("shard%d" % killed)
        assert sender.poll() is None, "the sender finished before the killed shard was back"
        consumer.drain_until_quiet(sender)
    finally:
        stage.stop_all()
    lost = 0
    for i in ids:
        g = consumer.gaps(i)
        if owner[i] == killed:
            seqs = consumer.order[i]
            assert g > 0, "stream %d: the kill lost nothing?" % i
            assert seqs[-1] == FRAMES - 1, "stream %d did not resume after the restart (last %d)" % (i, seqs[-1])
            lost += g
        else:
            assert g == 0, "stream %d (shard %d, not killed) has %d gaps" % (i, owner[i], g)
            same_as_reference(consumer, i)
    # The shards not killed account for every frame of theirs (the killed one's counters died with
    # it: its loss is the consumer's gaps above; so is the proxies' below, which count nothing per stream).
    for k in range(SHARDS):
        if k != killed:
            accounting.check({i: FRAMES for i in ids if owner[i] == k},
                             {i: len(consumer.order.get(i, [])) for i in ids},
                             accounting.load(stage.counters("shard%d" % k)), where="killed, shard %d" % k)
    print("killed shard %d: its %d streams resumed, %d frames lost and counted; other shards untouched"
          % (killed, len(killed_ids), lost))

    # 4. both proxies SIGKILLed and restarted while frames flow.
    stage, consumer = sharded_stage("proxies")
    try:
        sender = send(stage, stage.ep("fin"), "pub", SPEED, 2.0)
        assert consumer.pump(30, lambda: len(consumer.definitions) == STREAMS)
        assert consumer.pump(30, lambda: all(len(consumer.order.get(i, [])) >= 60 for i in ids))
        stage.kill("frames_proxy")
        stage.proxy("frames_proxy", "fin", "fout")
        assert consumer.pump(30, lambda: all(len(consumer.order.get(i, [])) >= 150 for i in ids)), \
            "streams did not resume after the frames proxy restarted"
        stage.kill("results_proxy")
        before = dict(consumer.definitions)
        stage.proxy("results_proxy", "rin", "rout")
        consumer.drain_until_quiet(sender)
    finally:
        stage.stop_all()
    lost = counted = 0
    # The proxies count nothing per stream: each shard's own stages balance, and what the hops
    # lost (frames before a shard took them, results after it published them) plus what the
    # shards dropped by a counted cause (frames from the restarted proxy before the next definition
    # reclaimed the orphaned stream: unauthorised) is exactly the consumer's gaps, stream by stream.
    in_hops = {}
    for k in range(SHARDS):
        in_hops.update(accounting.check_between_proxies(
            {i: FRAMES for i in ids if owner[i] == k}, {i: len(consumer.order.get(i, [])) for i in ids},
            accounting.load(stage.counters("shard%d" % k)), where="proxies, shard %d" % k))
    for i in ids:
        seqs = consumer.order[i]
        assert seqs[-1] == FRAMES - 1, "stream %d did not resume after the proxies restarted" % i
        assert consumer.definitions[i] > before.get(i, 0), "stream %d: no definition after the restart" % i
        hops, dropped = in_hops[i]
        assert hops + dropped == consumer.gaps(i), "stream %d: %d lost in the proxies + %d dropped != %d gaps" % (
            i, hops, dropped, consumer.gaps(i))
        lost += hops
        counted += dropped
    print("proxies restarted: every stream resumed; %d frames lost in the proxies + %d dropped by the shards "
          "(counted) = the consumer's gaps" % (lost, counted))
print("ok")
