// VMC out for `kata coach` (--vmc HOST:PORT: the ghost, --vmc-student HOST:PORT: the student):
// each performer's joints as a humanoid pose (kata/humanoid.h: a rig on its skeleton and layout)
// sent as one VMC bundle per frame (kata/vmc.h: kata_vmc_write_pose) over UDP to a VMC receiver
// (a Unity, Unreal, Blender or Godot avatar; docs/vmc.md).
//
// Threads: offer() is called by the thread that has a frame's joints (the coach's pushing thread,
// or the runtime's result thread): it copies them into a preallocated ring and returns; a full
// ring drops the frame and counts it. The sender thread of its own takes frames from the ring,
// poses them (the rigs are its alone), writes the bundles and sends them on a non-blocking UDP
// socket; a send that fails (no receiver, a full socket buffer) is counted, never retried, never
// waited on. So the coach's live path neither blocks nor allocates for VMC (the sender thread
// allocates inside liblo per bundle).
// A public-ABI client only (kata.h), as the rest of the coach.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "kata/kata.h"

namespace kata::coach {

// One performer's input: what its joints are and where its bundles go.
struct VmcPerformer {
  std::string target;               // "HOST:PORT" (an IPv4 address or a name), "" : not sent
  kata_skeleton skeleton = nullptr; // its joints (borrowed during construction only)
  std::string layout = "cmu";       // the layout the rig reads them with (kata_layout_name)
  kata_up_axis up_axis = KATA_UP_Y;
  double metres_per_unit = 0.0;     // 0: the layout's (kata_humanoid_desc)
};

struct VmcCounters {
  uint64_t offered = 0, dropped = 0;  // frames handed in; frames the full ring dropped
  uint64_t sent = 0, send_failed = 0; // bundles sent; sends that failed (counted, not retried)
  uint64_t pose_failed = 0;           // frames the rig refused (a joint not finite)
};

// Parses "HOST:PORT" (port 1..65535). False (and *why) for anything else. Inline: kata serve's
// config reader (serve_config.cpp, also built into its tests and fuzz target) checks targets with it.
inline bool parse_vmc_target(const std::string& text, std::string* host, int* port, std::string* why) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 >= text.size()) {
    *why = "'" + text.substr(0, 80) + "' is not HOST:PORT (e.g. 127.0.0.1:39539)";
    return false;
  }
  const std::string p = text.substr(colon + 1);
  if (p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos || std::stoi(p) < 1 ||
      std::stoi(p) > 65535) {
    *why = "port '" + p.substr(0, 16) + "' in '" + text.substr(0, 80) + "' is not 1..65535";
    return false;
  }
  *host = text.substr(0, colon);
  *port = std::stoi(p);
  return true;
}

// A VMC receiver's address: "HOST:PORT" resolved (IPv4) into a sockaddr for sendto. Throws
// kata::cli::Failure naming `what` (the option or config key) when it is not HOST:PORT or does not
// resolve.
std::vector<unsigned char> resolve_vmc_target(const std::string& target, const std::string& what);

class VmcOut {
 public:
  // Builds the rigs and the sockets (names resolved now) and starts the sender thread. Throws
  // kata::cli::Failure (a bad target, a rig the layout refuses). ring: frames held at most.
  VmcOut(kata_context context, const VmcPerformer& student, const VmcPerformer& ghost, size_t ring = 256);
  ~VmcOut();  // close()
  // Sends what is in the ring, then stops the sender thread (offer() then drops). Idempotent.
  // [the producer's thread]
  void close();
  VmcOut(const VmcOut&) = delete;
  VmcOut& operator=(const VmcOut&) = delete;

  // One frame: its time (seconds), the student's joints (student skeleton's count x 3, or NULL)
  // and the ghost's (ghost skeleton's count x 3, or NULL: none this frame). Never blocks, never
  // allocates. [one producer thread]
  void offer(double time, const float* student, const float* ghost);
  VmcCounters counters() const;
  bool sends_student() const { return student_.fd >= 0; }
  bool sends_ghost() const { return ghost_.fd >= 0; }

 private:
  struct Side {
    int fd = -1;
    std::vector<unsigned char> address;  // sockaddr storage of the target
    kata_humanoid_rig rig = nullptr;
    uint32_t joints = 0;
  };
  struct Slot {
    double time = 0.0;
    bool student = false, ghost = false;
    std::vector<float> student_xyz, ghost_xyz;
  };
  void open_side(kata_context context, const VmcPerformer& p, Side& side);
  void run();
  void send(Side& side, const float* xyz, double time, std::vector<unsigned char>& buffer);

  Side student_, ghost_;
  std::vector<Slot> ring_;
  std::atomic<uint64_t> head_{0}, tail_{0};  // produced / consumed slots
  std::atomic<bool> stop_{false};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::atomic<uint64_t> offered_{0}, dropped_{0}, sent_{0}, send_failed_{0}, pose_failed_{0};
  std::thread thread_;
};

// VMC out for `kata serve` ([vmc] in its config, docs/vmc.md): for each stream listed, its ghost
// and / or its student as VMC performers, each to its own HOST:PORT, at most `rate` bundles a
// second per performer.
//
// Threads: open() on the runtime's I/O thread (on_stream_open) builds the stream's rig
// (kata_humanoid_rig_create_for_stream: the student's frames and the stream's ghosts) and hands it
// to the sender thread through an atomic slot. offer_student() (the runtime's on_frame: the I/O
// thread, a source plugin's thread) and offer_ghost() (on_result: the thread holding the
// publisher) find the stream in a table fixed at start (binary search), thin to the rate and
// copy the joints into a bounded multi-producer ring allocated at start (a cell claimed by
// compare-and-swap: no lock; a full ring drops and counts). They never block or allocate. The
// sender thread of its own poses, writes and sends on one non-blocking UDP socket; a send that
// fails is counted, never retried or waited on.
struct VmcStreamTarget {
  uint64_t stream_id = 0;
  std::string ghost, student;  // "HOST:PORT", "" : that performer is not sent
  double rate = 0.0;           // bundles a second per performer at most; 0: every frame
  std::string where;           // "FILE:LINE" of its config entry (named in refusals)
};

class VmcStreams {
 public:
  struct Counters {
    uint64_t stream_id = 0;
    uint64_t offered = 0;      // frames and ghosts handed in
    uint64_t thinned = 0;      // not sent: within 1 / rate of the performer's previous bundle
    uint64_t dropped = 0;      // the ring was full
    uint64_t sent = 0;         // bundles sent
    uint64_t send_failed = 0;  // sends that failed (no receiver, a full socket buffer)
    uint64_t pose_failed = 0;  // frames the rig refused (a joint not finite, a new skeleton's
                               // frames in flight), or no rig (the stream's layout has none)
  };
  // Resolves every target and opens the socket; starts the sender thread. max_joints: the
  // largest frame (kata_runtime_desc.max_joints). Throws kata::cli::Failure naming the entry.
  VmcStreams(const std::vector<VmcStreamTarget>& streams, uint32_t max_joints, size_t ring = 1024);
  ~VmcStreams();
  VmcStreams(const VmcStreams&) = delete;
  VmcStreams& operator=(const VmcStreams&) = delete;
  // Sends what is in the ring and stops the sender (later offers are dropped). Idempotent.
  void close();
  // A stream opened (the runtime's on_stream_open, after its teacher was attached): its rig. A
  // stream not listed is ignored; a layout the rig refuses is told once on stderr, its frames
  // then counted in pose_failed. [the I/O thread]
  void open(uint64_t stream_id, kata_stream stream);
  // The live path (above). [any thread; one producer per stream and performer at a time]
  void offer_student(uint64_t stream_id, double time, const float* xyz, uint32_t joints);
  void offer_ghost(uint64_t stream_id, double time, const float* xyz, uint32_t joints);
  std::vector<Counters> counters() const;

 private:
  struct Entry {
    VmcStreamTarget target;
    uint32_t index = 0;  // in entries_
    std::vector<unsigned char> ghost_address, student_address;  // empty: not sent
    std::atomic<double> last_student{0.0}, last_ghost{0.0};
    std::atomic<bool> any_student{false}, any_ghost{false};
    std::atomic<kata_humanoid_rig> pending{nullptr};  // from open(), taken by the sender
    kata_humanoid_rig rig = nullptr;                  // the sender's
    std::atomic<uint64_t> offered{0}, thinned{0}, dropped{0}, sent{0}, send_failed{0}, pose_failed{0};
  };
  struct Cell {
    std::atomic<uint64_t> turn{0};
    uint32_t entry = 0, joints = 0;
    bool ghost = false;
    double time = 0.0;
  };
  Entry* find(uint64_t stream_id);
  void offer(uint64_t stream_id, bool ghost, double time, const float* xyz, uint32_t joints);
  void run();
  void send(Entry& e, const Cell& c, const float* xyz, std::vector<unsigned char>& buffer);

  std::vector<std::unique_ptr<Entry>> entries_;  // sorted by stream id
  uint32_t max_joints_ = 0;
  std::vector<Cell> cells_;
  std::vector<float> xyz_;  // cells x max_joints x 3
  uint64_t mask_ = 0;
  alignas(64) std::atomic<uint64_t> enqueue_{0};
  alignas(64) uint64_t dequeue_ = 0;
  int fd_ = -1;
  kata_context context_ = nullptr;  // open()'s: the rigs' errors
  std::atomic<bool> stop_{false};
  std::atomic<bool> sleeping_{false};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::thread thread_;
};

}  // namespace kata::coach
