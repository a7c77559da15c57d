"""Nothing lost, and proven so: the Python twin of tests/support/accounting.hpp for the
CLI tests (kata serve behind kata send, shards). Per stream:

  frames sent = results received + every drop cause kata serve --counters wrote + consumer gaps

and each stage's own balance, so that a missing frame is named by its stream and where it went:

  taken:     sent      = frames_in + queue_full + stopped + stale + unauthorised
             + out_of_sequence + wrong_joints
  computed:  frames_in = results + pipeline_dropped + refused
  handed on: results   = published + send_failed + result_queue_full
  received:  published = received + consumer gaps

The drop causes are whatever the file names besides frames_in, results and published (the
runtime's kDropCauses): a cause added there is balanced here without a change."""
import json

NOT_CAUSES = ("frames_in", "results", "published")


def load(path):
    """Every stream's counters from kata serve --counters PATH, by stream id (int)."""
    with open(path) as f:
        data = json.load(f)
    return {int(k): v for k, v in data["streams"].items()}


def unaccounted(stream, sent, received, c, gaps=0):
    """'' when the stream balances, else why not: the counts and the stage that lost the frame."""
    causes = {k: v for k, v in c.items() if k not in NOT_CAUSES}
    dropped = sum(causes.values())
    if sent == received + dropped + gaps:
        return ""
    why = "stream %d: %d frame(s) unaccounted for: sent %d != received %d + %s + consumer gaps %d;" % (
        stream, sent - received - dropped - gaps, sent, received,
        " + ".join("%s %d" % kv for kv in sorted(causes.items())), gaps)
    taken = c["frames_in"] + sum(c.get(k, 0) for k in ("queue_full", "stopped", "stale", "unauthorised",
                                                            "out_of_sequence", "wrong_joints"))
    if sent != taken:
        return why + " lost before a worker queue took it (sent %d, taken or refused %d)" % (sent, taken)
    if c["frames_in"] != c["results"] + c["pipeline_dropped"] + c["refused"]:
        return why + " lost in the worker: %d queued frame(s) neither computed nor refused" % (
            c["frames_in"] - c["results"] - c["pipeline_dropped"] - c["refused"])
    if c["results"] != c["published"] + c["send_failed"] + c["result_queue_full"]:
        return why + " lost between the worker and the I/O thread: %d result(s) neither published nor dropped" % (
            c["results"] - c["published"] - c["send_failed"] - c["result_queue_full"])
    return why + " lost after publishing: published %d, received %d, consumer gaps %d" % (
        c["published"], received, gaps)


def check(sent, received, counters, gaps=None, where=""):
    """Asserts every stream of `sent` ({stream: frames}) balances against `received` ({stream:
    results}) and `counters` (load()); gaps: {stream: results the consumer counted missing}."""
    gaps = gaps or {}
    failures = []
    for stream, n in sorted(sent.items()):
        if stream not in counters:
            failures.append("stream %d: not in the counters (never opened)" % stream)
            continue
        why = unaccounted(stream, n, received.get(stream, 0), counters[stream], gaps.get(stream, 0))
        if why:
            failures.append(why)
    assert not failures, (where + ": " if where else "") + "\n".join(failures)


def check_between_proxies(sent, received, counters, where=""):
    """For a stream whose frames and results crossed a hop that counts nothing per stream (a
    kata proxy killed and restarted): the runtime's own stages must balance exactly, what it took
    cannot exceed what was sent, nor what was received what it published. Returns {stream:
    (frames lost in the hops, frames the runtime dropped with a counted cause)}: hops = (sent -
    taken) + (published - received); the two add up to the consumer's gaps."""
    failures, lost = [], {}
    for stream, n in sorted(sent.items()):
        c = counters.get(stream)
        if c is None:
            failures.append("stream %d: not in the counters (never opened)" % stream)
            continue
        taken = c["frames_in"] + sum(c.get(k, 0) for k in ("queue_full", "stopped", "stale", "unauthorised",
                                                                "out_of_sequence", "wrong_joints"))
        got = received.get(stream, 0)
        if taken > n:
            failures.append("stream %d: took %d frames of %d sent" % (stream, taken, n))
        if c["frames_in"] != c["results"] + c["pipeline_dropped"] + c["refused"]:
            failures.append("stream %d: lost in the worker (frames_in %d, results %d)" % (stream, c["frames_in"], c["results"]))
        if c["results"] != c["published"] + c["send_failed"] + c["result_queue_full"]:
            failures.append("stream %d: lost between the worker and the I/O thread (results %d, published %d)"
                            % (stream, c["results"], c["published"]))
        if got > c["published"]:
            failures.append("stream %d: received %d > published %d" % (stream, got, c["published"]))
        dropped = sum(v for k, v in c.items() if k not in NOT_CAUSES)
        lost[stream] = ((n - taken) + (c["published"] - got), dropped)
    assert not failures, (where + ": " if where else "") + "\n".join(failures)
    return lost
