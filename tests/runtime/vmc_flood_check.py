#!/usr/bin/python3
"""A flood of VMC bundles into `kata serve`'s vmc-in beside a clean stream, every datagram accounted for.

kata serve runs two streams: 7, CMU 07_01 from `kata send` over the ZeroMQ ingest (300 frames at
120 Hz, played as often as the flood lasts), and 8, a vmc-in source taking a flood of well-formed VMC bundles (22 bones, about 1.2 KB,
each with a later /VMC/Ext/T) paced at RATE bundles a second for SECONDS. Figures printed, and
checked:
- sent: the bundles this script handed to the kernel (and the rate it reached);
- dropped by the kernel: the vmc-in socket's own drop counter (/proc/net/udp, its "drops" column:
  datagrams that found its receive buffer full), and the host's Udp RcvbufErrors (/proc/net/snmp,
  every socket on the host, for reference);
- counted by vmc-in: the datagrams it read and parsed (packets), those over its datagram budget
  (over_budget: taken off the socket unread; packets + over_budget = sent - the socket's drops,
  exactly), and of the frames read, those pushed (at most max_rate a second) and those over the rate;
- stream 7: every frame in is a result, every result published (--counters), nothing dropped;
- kata serve's RSS before and after the flood (VmRSS), bounded.

    /usr/bin/python3 tests/runtime/vmc_flood_check.py build/bin/kata . build/plugins [SECONDS] [RATE]

(ctest runs 2 s at 100,000 a second; docs/vmc.md has a 10 s run.) Ports: free UDP ports from the
kernel; paths: a temporary directory."""
import json, os, signal, socket, struct, subprocess, sys, tempfile, time

import liblo

kata_cli, source, plugin_dir = (os.path.abspath(a) for a in sys.argv[1:4])
sys.path.insert(0, os.path.join(source, "tests", "transport"))
from vmc_peer import free_udp_port, liblo_bytes, rss_kib  # noqa: E402
SECONDS = float(sys.argv[4]) if len(sys.argv) > 4 else 2.0
RATE = float(sys.argv[5]) if len(sys.argv) > 5 else 100000.0
LOOPS = max(1, -int(-SECONDS // 2.5))  # stream 7 plays 300 frames (2.5 s) this often: as long as the flood
FRAMES = 300 * LOOPS
BONES = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
         "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg",
         "LeftFoot", "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"]


def cpu_seconds(pid):
    """User + system CPU seconds of every thread of the process so far (/proc/PID/stat)."""
    f = open("/proc/%d/stat" % pid).read().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def socket_drops(port):
    """The drops column of the IPv4 UDP socket bound to 127.0.0.1:port (/proc/net/udp)."""
    want = "0100007F:%04X" % port
    for line in open("/proc/net/udp").read().splitlines()[1:]:
        f = line.split()
        if f[1] == want:
            return int(f[-1])
    raise AssertionError("no UDP socket on 127.0.0.1:%d" % port)


def rcvbuf_errors():
    lines = [l.split() for l in open("/proc/net/snmp") if l.startswith("Udp:")]
    return int(lines[1][lines[0].index("RcvbufErrors")])


# A well-formed bundle of every bone (identity rotations, zero positions: a rotations-only sender);
# /VMC/Ext/T is its last four bytes, rewritten for each bundle so that every frame is later.
base = bytearray(liblo_bytes(liblo.Bundle(
    liblo.Message("/VMC/Ext/Root/Pos", "root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
    *[liblo.Message("/VMC/Ext/Bone/Pos", b, 0.0, 0.9 if b == "Hips" else 0.0, 0.0, 0.0, 0.0, 0.0, 1.0) for b in BONES],
    liblo.Message("/VMC/Ext/OK", 1), liblo.Message("/VMC/Ext/T", 0.0))))
assert struct.unpack(">f", base[-4:])[0] == 0.0

with tempfile.TemporaryDirectory(prefix="kata_vmc_flood_") as tmp:
    port = free_udp_port()
    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write(
        '[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\n[publish]\nendpoints = ["ipc://%s/out"]\n'
        '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s/data/cmu/02_01.bvh"\n'
        '[[plugins]]\npath = "%s/vmc-in.so"\nconfig = "port=%d;stream=8"\n' % (tmp, tmp, source, source, plugin_dir, port))
    counters_file = os.path.join(tmp, "counters.json")
    serve = subprocess.Popen([kata_cli, "serve", "--config", config, "--counters", counters_file],
                             stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 30
        while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline and serve.poll() is None:
            time.sleep(0.05)
        assert serve.poll() is None, "kata serve did not start"
        time.sleep(0.5)
        # Stream 7 beside the flood, at the clip's rate; RSS measured once it is open.
        sender = subprocess.Popen([kata_cli, "send", "--bvh", os.path.join(source, "data", "cmu", "07_01.bvh"),
                                   "--endpoint", "ipc://%s/in" % tmp, "--stream-id", "7", "--layout", "cmu",
                                   "--first-frame", "1", "--frames", "300", "--loops", str(LOOPS)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(0.3)
        rss0, drops0, errors0, cpu0 = rss_kib(serve.pid), socket_drops(port), rcvbuf_errors(), cpu_seconds(serve.pid)
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.connect(("127.0.0.1", port))
        send, pack, clock, at = s.send, struct.pack_into, time.monotonic, len(base) - 4
        total = int(SECONDS * RATE)
        sent, t0 = 0, clock()
        while sent < total:  # paced in steps of 100 bundles (1 ms at 100,000 a second)
            due = min(total, int((clock() - t0) * RATE) + 100)
            while sent < due:
                pack(">f", base, at, sent * 1e-5)  # 10 us apart: exact in float32 up to 16 s
                try:
                    send(base)
                except (BlockingIOError, ConnectionRefusedError):
                    continue
                sent += 1
        elapsed = time.monotonic() - t0
        cpu1 = cpu_seconds(serve.pid)
        _, err = sender.communicate(timeout=60)
        assert sender.returncode == 0, err
        time.sleep(1.0)
        rss1, drops1, errors1 = rss_kib(serve.pid), socket_drops(port), rcvbuf_errors()
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=60)
    assert serve.returncode == 0, err
    counters = json.load(open(counters_file))

line = [l for l in err.splitlines() if l.startswith("vmc-in: stream 8 ")]
assert line, err
vmc_in = {k: int(v) for k, v in (item.split() for item in line[0].split(": ", 2)[2].split(", "))}
dropped = drops1 - drops0
c7 = counters["streams"]["7"]
print("flood: %d bundles sent in %.2f s (%.0f a second); the kernel dropped %d at the vmc-in socket (host RcvbufErrors "
      "+%d); vmc-in took %d unread (over its datagram budget) and read %d (%d frames pushed, %d over its rate, %d "
      "malformed); stream 7: %d frames in, %d results, %d "
      "published; kata serve RSS %d -> %d KiB (%+d KiB), CPU %.2f s over the flood's %.2f s" %
      (sent, elapsed, sent / elapsed, dropped, errors1 - errors0, vmc_in["over_budget"], vmc_in["packets"], vmc_in["pushed"],
       vmc_in["over_rate"], vmc_in["malformed"], c7["frames_in"], c7["results"], c7["published"], rss0, rss1,
       rss1 - rss0, cpu1 - cpu0, elapsed))
assert vmc_in["packets"] + vmc_in["over_budget"] + dropped == sent, \
    "every bundle read, taken unread or dropped by the kernel: %d + %d + %d != %d" % (
        vmc_in["packets"], vmc_in["over_budget"], dropped, sent)
assert vmc_in["malformed"] == 0 and vmc_in["frames"] == vmc_in["packets"], vmc_in
assert vmc_in["pushed"] + vmc_in["over_rate"] == vmc_in["frames"], vmc_in
assert c7["frames_in"] == FRAMES and c7["results"] == FRAMES and c7["published"] == FRAMES, c7
assert all(c7[k] == 0 for k in ("queue_full", "refused", "pipeline_dropped", "result_queue_full", "send_failed")), c7
assert rss1 - rss0 < 64 * 1024, "kata serve grew %d KiB under the flood" % (rss1 - rss0)
