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

// Parses "HOST:PORT" (port 1..65535). False (and *why) for anything else.
bool parse_vmc_target(const std::string& text, std::string* host, int* port, std::string* why);

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

}  // namespace kata::coach
