// VMC out for kata coach (vmc_out.hpp).
#include "coach/vmc_out.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>

#include "failure.hpp"

namespace kata::coach {

bool parse_vmc_target(const std::string& text, std::string* host, int* port, std::string* why) {
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

void VmcOut::open_side(kata_context context, const VmcPerformer& p, Side& side) {
  if (p.target.empty()) return;
  std::string host, why;
  int port = 0;
  if (!parse_vmc_target(p.target, &host, &port, &why)) cli::fail("--vmc: " + why);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || !found)
    cli::fail("--vmc: cannot resolve '" + host.substr(0, 80) + "'");
  side.address.assign(reinterpret_cast<unsigned char*>(found->ai_addr),
                      reinterpret_cast<unsigned char*>(found->ai_addr) + found->ai_addrlen);
  freeaddrinfo(found);
  side.fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (side.fd < 0) cli::fail("--vmc: no UDP socket: " + std::string(std::strerror(errno)));
  kata_humanoid_desc d;
  kata_humanoid_desc_init(&d);
  d.layout = p.layout.c_str();
  d.up_axis = p.up_axis;
  d.metres_per_unit = p.metres_per_unit;
  if (kata_humanoid_rig_create(context, p.skeleton, &d, &side.rig) != KATA_OK)
    cli::fail("--vmc: " + std::string(kata_context_last_error(context)));
  side.joints = kata_skeleton_joint_count(p.skeleton);
}

VmcOut::VmcOut(kata_context context, const VmcPerformer& student, const VmcPerformer& ghost, size_t ring) {
  try {
    open_side(context, student, student_);
    open_side(context, ghost, ghost_);
  } catch (...) {
    for (Side* s : {&student_, &ghost_}) {
      if (s->fd >= 0) ::close(s->fd);
      kata_humanoid_rig_destroy(s->rig);
    }
    throw;
  }
  ring_.resize(ring < 2 ? 2 : ring);
  for (Slot& s : ring_) {
    s.student_xyz.resize(3 * static_cast<size_t>(student_.joints));
    s.ghost_xyz.resize(3 * static_cast<size_t>(ghost_.joints));
  }
  thread_ = std::thread([this] { run(); });
}

void VmcOut::close() {
  stop_.store(true, std::memory_order_release);
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

VmcOut::~VmcOut() {
  close();
  for (Side* s : {&student_, &ghost_}) {
    if (s->fd >= 0) ::close(s->fd);
    kata_humanoid_rig_destroy(s->rig);
  }
}

void VmcOut::offer(double time, const float* student, const float* ghost) {
  offered_.fetch_add(1, std::memory_order_relaxed);
  if (stop_.load(std::memory_order_relaxed)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const uint64_t head = head_.load(std::memory_order_relaxed);
  if (head - tail_.load(std::memory_order_acquire) >= ring_.size()) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Slot& s = ring_[head % ring_.size()];
  s.time = time;
  s.student = student && student_.fd >= 0;
  s.ghost = ghost && ghost_.fd >= 0;
  if (s.student) std::memcpy(s.student_xyz.data(), student, sizeof(float) * s.student_xyz.size());
  if (s.ghost) std::memcpy(s.ghost_xyz.data(), ghost, sizeof(float) * s.ghost_xyz.size());
  head_.store(head + 1, std::memory_order_release);
  wake_.notify_one();
}

VmcCounters VmcOut::counters() const {
  VmcCounters c;
  c.offered = offered_.load();
  c.dropped = dropped_.load();
  c.sent = sent_.load();
  c.send_failed = send_failed_.load();
  c.pose_failed = pose_failed_.load();
  return c;
}

void VmcOut::send(Side& side, const float* xyz, double time, std::vector<unsigned char>& buffer) {
  kata_humanoid_pose pose;
  pose.struct_size = sizeof pose;
  if (kata_humanoid_rig_pose(side.rig, xyz, side.joints, KATA_HUMANOID_RIGHT_HANDED, &pose) != KATA_OK) {
    pose_failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  size_t size = 0;
  if (kata_vmc_write_pose(&pose, time, 1.0f, buffer.data(), buffer.size(), &size) != KATA_OK) {
    pose_failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const ssize_t n = sendto(side.fd, buffer.data(), size, MSG_DONTWAIT | MSG_NOSIGNAL,
                           reinterpret_cast<const sockaddr*>(side.address.data()),
                           static_cast<socklen_t>(side.address.size()));
  if (n == static_cast<ssize_t>(size)) sent_.fetch_add(1, std::memory_order_relaxed);
  else send_failed_.fetch_add(1, std::memory_order_relaxed);
}

void VmcOut::run() {
  std::vector<unsigned char> buffer(8192);  // a bundle of every bone is under 2 KiB (kata/vmc.h)
  for (;;) {
    const uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) {
      if (stop_.load(std::memory_order_acquire)) return;
      std::unique_lock<std::mutex> lock(wake_mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(5));  // offer() never takes the lock: poll too
      continue;
    }
    Slot& s = ring_[tail % ring_.size()];
    if (s.student) send(student_, s.student_xyz.data(), s.time, buffer);
    if (s.ghost) send(ghost_, s.ghost_xyz.data(), s.time, buffer);
    tail_.store(tail + 1, std::memory_order_release);
  }
}

}  // namespace kata::coach
