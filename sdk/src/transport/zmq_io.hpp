// ZeroMQ sockets of the runtime: a publisher of results and skeleton definitions, and an
// ingest of frames and skeleton definitions. ZeroMQ sockets are not thread-safe: each object
// here is used by one thread at a time (the ingest: the runtime's I/O thread; the publisher:
// whichever runtime thread holds its token, handed over with a full memory barrier, as ZeroMQ
// asks when a socket changes thread), counters included (the runtime copies them out).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "transport/curve.hpp"
#include "transport/ingest_table.hpp"
#include "transport/people_frame.hpp"
#include "transport/wire.hpp"

namespace kata::transport {

// A ZeroMQ context (thread-safe), shared by every socket of a process part.
class Context {
 public:
  explicit Context(int io_threads = 1);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  void* get() const { return context_; }
  // Starts the context's ZAP handler (curve.hpp) with this allow-list of client public keys,
  // before any CURVE server socket binds (a handler already running, started by number_connections,
  // takes the list). Throws kata::Error(kIo).
  void authenticate(std::vector<std::string> allowed_client_keys);
  // Starts the ZAP handler, with an empty allow-list, unless it runs: a keyless ingest's
  // connections are numbered by it (curve.hpp, kConnectionDomain). Throws kata::Error(kIo).
  void number_connections();
  const ZapHandler* zap() const { return zap_.get(); }

 private:
  void* context_;
  std::unique_ptr<ZapHandler> zap_;
};

// Options every kata socket shares: CURVE, the largest message ZeroMQ accepts (ZMQ_MAXMSGSIZE:
// a peer sending more is disconnected before the message is buffered) and the time a peer has to
// complete its handshake (ZMQ_HANDSHAKE_IVL: a silent connection is closed, freeing its descriptor).
struct SocketSecurity {
  CurveOptions curve;
  int64_t max_message_bytes = 1 << 20;
  int handshake_ms = 2000;
};
// Applies them to a socket before it binds or connects. Throws kata::Error(kIo).
void apply_security(void* socket, const SocketSecurity& security);

struct PublisherOptions {
  // Endpoints to bind (tcp://127.0.0.1:5555, ipc:///tmp/kata.sock, ...). At least one.
  // "connect:" before an endpoint connects it instead: a shard's publisher connects to the
  // frontend (XSUB) of a `kata proxy` that consumers subscribe behind (docs/deploy.md); it
  // still sees every subscription the proxy forwards, so joins re-send skeleton definitions.
  std::vector<std::string> endpoints;
  // ZMQ_SNDHWM: messages queued per subscriber before ZeroMQ drops that subscriber's newest
  // (ZeroMQ's per-subscriber drops; they show as result_sequence gaps at the subscriber).
  int send_hwm = 10000;
  // ZMQ_LINGER, milliseconds: how long results already handed to ZeroMQ when the publisher
  // closes (Runtime::stop sends every result before it returns) may still go out to connected
  // subscribers; the runtime's destruction waits for them at most this long. 0 drops them at
  // close; -1 waits without a limit.
  int linger_ms = 2000;
  // CURVE and limits (subscribers send only subscriptions: a small ZMQ_MAXMSGSIZE).
  SocketSecurity security{CurveOptions{}, 4096, 2000};
};

// An XPUB socket: publishes never block (ZMQ_DONTWAIT; a PUB drops at the high-water mark
// rather than block) and it sees each subscription (ZMQ_XPUB_VERBOSE), so the runtime re-sends
// the skeleton definitions a joining subscriber asked for.
class Publisher {
 public:
  // Binds (or connects) every endpoint. Throws kata::Error(kIo) naming the endpoint and ZeroMQ's reason.
  Publisher(Context& context, const PublisherOptions& options);
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  // Sends one message without blocking; false (and counted in failed()) when ZeroMQ refused it.
  bool send(Bytes message);
  // Reads pending subscription messages without blocking; calls on_join(prefix, prefix_size)
  // for every subscribe (prefix empty = every topic). Returns how many were read.
  int poll_joins(const std::function<void(const uint8_t* prefix, size_t size)>& on_join);
  // The socket, for zmq_poll (POLLIN = subscription messages).
  void* socket() const { return socket_; }  // null for kDirect
  // ZMQ_FD: a plain descriptor another thread may poll while the socket's owner of the moment
  // sends (edge-triggered: after it fires, poll_joins reads until nothing is left).
  int descriptor() const;
  // Subscription messages wait to be read (ZMQ_EVENTS has POLLIN; a send may have moved them
  // in from ZeroMQ's command queue without the descriptor firing again).
  bool joins_waiting() const;
  // The last endpoint bound, resolved (a "tcp://127.0.0.1:*" bind reports its port).
  std::string endpoint() const;

  uint64_t sent() const { return sent_; }
  uint64_t failed() const { return failed_; }

 private:
  void* socket_ = nullptr;
  uint64_t sent_ = 0, failed_ = 0;
};

// kDirect: no socket. Messages are handed in by another thread of the process (a NATS shard's
// delivery thread: Runtime::offer copies them into a ring the ingest's thread reads, then
// Ingest::receive), so they reach the same verifier, limits, table and counters as a socket's
// without a local hop. They all count as one sender's (kLocalSender): who may publish on a
// stream's subject is the transport's business (NATS account permissions).
enum class IngestKind { kSub, kPull, kDirect };

// Reads one event of a zmq_socket_monitor PAIR socket without blocking: its kind (ZMQ_EVENT_*)
// and value (a descriptor, an error or a status, by kind). False when none is waiting.
bool read_socket_event(void* monitor, uint16_t* kind, uint32_t* value);

struct IngestOptions {
  // Endpoints; "bind:" before an endpoint binds it, otherwise it is connected (a SUB connects
  // to a mocap stage's PUB; a PULL usually binds so several senders can push to it). None for
  // kDirect.
  std::vector<std::string> endpoints;
  IngestKind kind = IngestKind::kSub;
  // kDirect: bytes of the ring messages wait in for the ingest's thread (allocated once; a
  // message that finds no room is refused to its sender, who counts it). 4 MiB holds ~4,000
  // frames of 33 joints, seconds of 16 streams x 60 Hz; raised to hold 2 messages of the limit.
  size_t direct_queue_bytes = 4 << 20;
  // Largest message accepted; larger ones are counted as oversized and dropped.
  size_t max_message_bytes = 1 << 20;
  // ZMQ_RCVHWM.
  int receive_hwm = 10000;
  // Refuse frames without Frame.checksum (schemas/frame.fbs).
  bool require_checksum = true;
  // Sharding (docs/deploy.md): this ingest keeps only the streams with
  // shard_of(stream id, shard_count) == shard_index; the others' messages are counted in
  // other_shard and dropped after reading the topic (nothing else is parsed).
  uint32_t shard_count = 1;
  uint32_t shard_index = 0;
  // Who may send what (ingest_table.hpp): streams per sender and in all, the sequence window,
  // stale frames, idle expiry.
  IngestLimits limits;
  // Connections held at once (bound endpoints); one more is closed at once (connections_refused).
  // 0: no limit.
  uint32_t max_connections = 256;
  // CURVE (a server, or a client of curve.remote_server); its max_message_bytes is replaced by
  // 4 x the limit above (ZMQ_MAXMSGSIZE: a larger message drops its sender unread).
  SocketSecurity security;
  // Log the first refusal of each cause per sender on stderr (the fuzz target turns it off).
  bool log_refusals = true;
};

// What the ingest counted. Every received message lands in exactly one of frames, skeletons,
// repeated_skeletons, closes, practices, repeated_practices, other_shard or a drop counter; a
// frame batch (schemas/frame_batch.fbs) that passed the verifier counts as its frames, each of
// which lands in exactly one of them: received - batches + batch_frames = the sum (items()).
struct IngestCounters {
  uint64_t received = 0;       // messages read from the socket
  uint64_t batches = 0;        // frame batches verified (their frames are judged one by one)
  uint64_t batch_frames = 0;   // the frames those batches carried
  uint64_t frames = 0;         // frames handed on
  uint64_t skeletons = 0;      // skeleton definitions handed on (new streams and revisions)
  uint64_t repeated_skeletons = 0;  // periodic re-sends of a known revision (not handed on)
  uint64_t malformed[static_cast<int>(DecodeError::kCount)] = {};  // by reason
  uint64_t refused_skeletons = 0;   // verified but inconsistent / refused by the receiver
  uint64_t unknown_stream = 0;      // a frame before its stream's skeleton definition
  uint64_t wrong_joint_count = 0;   // a frame whose joint count differs from its definition
  uint64_t out_of_order = 0;        // sequence not after the last one (and not a restart)
  uint64_t other_kind = 0;          // a valid kata message that is not ingest's (a Result)
  uint64_t restarts = 0;            // sequence back to 0: the source restarted (frame handed on)
  uint64_t sequence_gaps = 0;       // frames missing between accepted ones (not messages)
  uint64_t other_shard = 0;         // messages of streams another shard owns (not refused)
  // Who may send what (since 0.3; ingest_table.hpp).
  uint64_t not_owner = 0;           // a definition, close or frame from a sender that does not own the stream
  uint64_t refused_limit = 0;       // a definition beyond a streams limit (nothing allocated)
  uint64_t out_of_window = 0;       // a sequence too far after the last one
  uint64_t stale = 0;               // a frame older than max_frame_age by the stream's clock
  uint64_t closes = 0;              // streams closed by their owner (messages; not refused)
  uint64_t expired = 0;             // streams closed for idleness (not messages)
  uint64_t revisions = 0;           // new revisions from the owner that restarted a stream (in skeletons)
  // Practice settings (schemas/practice.fbs; since 1.0): applied, re-sent (not handed on, not a
  // drop), and refused by cause (drops; those of another sender are in not_owner, before their
  // stream's definition in unknown_stream, malformed ones in malformed).
  uint64_t practices = 0;
  uint64_t repeated_practices = 0;
  uint64_t practice_bad_values = 0;    // not finite, negative, an empty loop, a start and a loop
  uint64_t practice_outside_clip = 0;  // outside the stream's teacher clip
  uint64_t practice_no_clip = 0;       // the stream has no clip teacher
  uint64_t practice_queue_full = 0;    // the stream's worker queue was full
  uint64_t connections = 0;         // connections accepted or made (not messages)
  uint64_t disconnections = 0;      // connections closed (by the peer, ZeroMQ's limits or ours)
  uint64_t connections_refused = 0; // connections closed at once: max_connections reached
  // Connections closed before their ZeroMQ handshake finished: socket kinds that cannot talk (a
  // PUSH sender on a SUB ingest), CURVE on one side only, peers that never
  // spoke ZeroMQ (not those closed for max_connections: connections_refused). last_handshake_error: the ZMQ_PROTOCOL_ERROR_* (or ZAP status) of the
  // last failure ZeroMQ reported with a reason (0: none; socket kinds that cannot talk have none).
  uint64_t handshake_failures = 0;
  uint32_t last_handshake_error = 0;
  // Of the frames handed on, the people frames (schemas/people_frame.fbs; since 1.1: a frame of
  // their group stream; refused ones are in the causes above), and the poses they carried.
  uint64_t people_frames = 0;
  uint64_t people_poses = 0;
  // The source's age of every frame handed on: arrival - capture beyond the stream's quickest
  // delivery (ingest_table.hpp), in the runtime's latency buckets (2^(i/8) ns, kAgeBuckets).
  static constexpr int kAgeBuckets = 8 * 36;
  uint64_t age_histogram[kAgeBuckets] = {};
  uint64_t malformed_total() const;
  uint64_t dropped_total() const;   // every message refused (repeated skeletons are not refused)
  // What the outcome counters add up to: messages, a verified batch counted as its frames.
  uint64_t items() const { return received - batches + batch_frames; }
};

// A SUB (subscribed to every topic) or PULL socket reading kata frames and skeleton
// definitions. Every message passes the verifier; anything else is counted and dropped and
// never stalls the stream it claims to belong to.
class Ingest {
 public:
  struct Handlers {
    // A new stream or a new revision of one. Return false to refuse it (its frames are then
    // counted as unknown_stream). Called on the ingest's thread.
    std::function<bool(const SkeletonDefinition&)> on_skeleton;
    // A frame of a known stream, in order. restarted: the source restarted (sequence 0 after
    // later ones): the receiver should restart the stream's kinetics.
    std::function<void(const FrameView&, bool restarted)> on_frame;
    // A new revision of an open stream from its owner: the receiver restarts the stream with it.
    // Return false to refuse it (counted in refused_skeletons; the stream keeps the old one).
    std::function<bool(const SkeletonDefinition&)> on_revision;
    // A definition on_skeleton or on_revision refused with a reason (kata::Error's message): the
    // receiver tells the source (kata serve publishes it on the stream's results topic, a
    // skeleton message with `refused` set). Once per definition received. [ingest's thread]
    std::function<void(const SkeletonDefinition&, const std::string& why)> on_refused_definition;
    // The stream ended (its owner closed it, or it was idle past the limit). [ingest's thread]
    std::function<void(uint64_t stream_id)> on_close;
    // A frame of a known stream refused (stale, not its owner's, out of order or of the window,
    // the wrong joint count), besides the ingest-wide counter: the receiver counts it on the
    // stream, so that every frame sent for a stream is accounted for there. [ingest's thread]
    std::function<void(uint64_t stream_id, TableVerdict cause)> on_refused_frame;
    // A practice setting of a known stream from its owner, its values usable (not finite,
    // negative, an empty loop and a start beside a loop were refused before): the receiver
    // applies it in order with the stream's frames and returns kAccepted, or refuses it with
    // kPracticeOutsideClip / kPracticeNoClip / kPracticeQueueFull / kUnknownStream and says why
    // in *why (logged once per sender and cause). [ingest's thread]
    std::function<TableVerdict(const PracticeSetting&, std::string* why)> on_practice;
    // A people frame of a known group stream, in order (judged as a frame of that stream; its
    // poses are the receiver's to judge). [ingest's thread]
    std::function<void(const PeopleFrameView&, bool restarted)> on_people;
  };

  Ingest(Context& context, const IngestOptions& options, Handlers handlers);
  ~Ingest();
  Ingest(const Ingest&) = delete;
  Ingest& operator=(const Ingest&) = delete;

  // Reads up to max_messages without blocking. Returns how many were read.
  int poll(int max_messages);
  // Handles one message's bytes as if the socket had delivered it from `sender` at now_ns
  // (steady clock; counted the same way; the fuzz target drives the ingest's whole path through
  // it). [the ingest's thread]
  void handle(const void* data, size_t size, SenderToken sender = kLocalSender, int64_t now_ns = -1);
  // A message of a kDirect ingest (handed in, not read from a socket): counted as received and
  // handled as a socket's message from kLocalSender, now. [the ingest's thread]
  void receive(const void* data, size_t size);
  // Connection events (the connection limit, orphaned streams) and idle expiry; poll() calls it,
  // and the owner of the socket calls it at least every 100 ms. [the ingest's thread]
  void housekeeping(int64_t now_ns = -1);
  // Forgets every stream, sender and counter: the state of a new ingest, without a new socket
  // (the fuzz target runs each input on a fresh state). [the ingest's thread]
  void reset();
  void* socket() const { return socket_; }  // null for kDirect
  // The last endpoint bound or connected, resolved (a "bind:tcp://127.0.0.1:*" reports its port).
  std::string endpoint() const;
  const IngestCounters& counters() const { return counters_; }

 private:
  void refused(SenderToken sender, TableVerdict cause, uint64_t stream_id, const std::string& why = {});
  // The decoder's current frame (a Frame message's, or a batch's frame i): the table's rules, then on.
  void handle_frame(SenderToken sender, int64_t now_ns);
  // One frame's judgement by the stream table and its counters (a Frame message's, a people
  // frame's): true if accepted (*restarted: the source restarted its sequence); a refusal is
  // counted by cause and reported (on_refused_frame, refused) here.
  bool admit_frame(SenderToken sender, uint64_t stream_id, uint64_t sequence, int64_t capture_ns, int joints,
                   int64_t now_ns, bool* restarted);
  void handle_batch(SenderToken sender, int64_t now_ns);
  void handle_practice(SenderToken sender, int64_t now_ns);
  // A people frame (people_ingest.cpp): verified by its own decoder, then judged as a frame.
  void handle_people(const void* data, size_t size, SenderToken sender, int64_t now_ns);
  std::string describe(SenderToken sender) const;
  void* socket_ = nullptr;
  void* monitor_ = nullptr;  // PAIR socket reading this socket's connection events
  Decoder decoder_;
  PeopleFrameDecoder people_decoder_;
  uint32_t shard_count_ = 1, shard_index_ = 0;
  uint32_t max_connections_ = 0;
  bool log_refusals_ = true;
  Handlers handlers_;
  IngestTable table_;
  IngestCounters counters_;
  // Reads the connection events waiting (the limit on connections, orphaned streams).
  void read_connection_events();
  // Who sent a message that arrived on descriptor `fd` with the connection number `number` (a
  // keyless ingest: the ZAP handler numbers its connections, curve.hpp).
  SenderToken numbered_connection(int fd, uint64_t number);
  // Who sent a message that arrived on descriptor `fd` without a User-Id (a CURVE client ingest,
  // whose single upstream is the server it trusts): the descriptor and its generation.
  SenderToken connection_of(int fd);
  // Per connection descriptor, from the connection events: whether a connection holds it now and
  // its generation (bumped when its connection closes). From the messages: the newest connection
  // number seen on it (a smaller one is an earlier connection, closed) and whether that
  // connection is taken to hold the descriptor still.
  struct Connection {
    uint32_t generation = 0;
    bool open = false;
    bool by_descriptor = false;  // messages were attributed by generation (connection_of)
    bool holder_open = false;
    uint64_t holder = 0;
  };
  std::unordered_map<int, Connection> connections_;
  void holder_gone(Connection& c);
  bool numbered_ = false;  // a keyless ingest: messages carry their connection's number
  uint32_t open_connections_ = 0;
  int64_t next_expiry_ns_ = 0;
  std::vector<uint64_t> expired_;
  std::vector<uint64_t> logged_definition_refusals_;  // streams whose refused definition was logged (bounded)
  std::vector<int> handshaking_;  // descriptors of connections whose handshake has not finished
};

}  // namespace kata::transport
