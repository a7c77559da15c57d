// VMC out for kata coach (vmc_out.hpp).
#include "coach/vmc_out.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "failure.hpp"

namespace kata::coach {

std::vector<unsigned char> resolve_vmc_target(const std::string& target, const std::string& what) {
  std::string host, why;
  int port = 0;
  if (!parse_vmc_target(target, &host, &port, &why)) cli::fail(what + ": " + why);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || !found)
    cli::fail(what + ": cannot resolve '" + host.substr(0, 80) + "'");
  std::vector<unsigned char> address(reinterpret_cast<unsigned char*>(found->ai_addr),
                                     reinterpret_cast<unsigned char*>(found->ai_addr) + found->ai_addrlen);
  freeaddrinfo(found);
  return address;
}

void VmcOut::open_side(kata_context context, const VmcPerformer& p, Side& side) {
  if (p.target.empty()) return;
  side.address = resolve_vmc_target(p.target, "--vmc");
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

// ---- kata serve's [vmc] ----------------------------------------------------------------------

VmcStreams::VmcStreams(const std::vector<VmcStreamTarget>& streams, uint32_t max_joints, size_t ring)
    : max_joints_(max_joints) {
  for (const VmcStreamTarget& t : streams) {
    auto e = std::make_unique<Entry>();
    e->target = t;
    if (!t.ghost.empty()) e->ghost_address = resolve_vmc_target(t.ghost, t.where + ": ghost");
    if (!t.student.empty()) e->student_address = resolve_vmc_target(t.student, t.where + ": student");
    entries_.push_back(std::move(e));
  }
  std::sort(entries_.begin(), entries_.end(),
            [](const std::unique_ptr<Entry>& a, const std::unique_ptr<Entry>& b) {
              return a->target.stream_id < b->target.stream_id;
            });
  for (size_t i = 0; i < entries_.size(); ++i) entries_[i]->index = static_cast<uint32_t>(i);
  size_t n = 2;
  while (n < ring) n *= 2;
  cells_ = std::vector<Cell>(n);
  for (size_t i = 0; i < n; ++i) cells_[i].turn.store(i, std::memory_order_relaxed);
  mask_ = n - 1;
  xyz_.assign(n * 3 * static_cast<size_t>(max_joints_), 0.0f);
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) cli::fail("[vmc]: no UDP socket: " + std::string(std::strerror(errno)));
  if (kata_context_create(&context_) != KATA_OK) {
    ::close(fd_);
    cli::fail("[vmc]: no kata context");
  }
  thread_ = std::thread([this] { run(); });
}

void VmcStreams::close() {
  stop_.store(true, std::memory_order_release);
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

VmcStreams::~VmcStreams() {
  close();
  if (fd_ >= 0) ::close(fd_);
  for (auto& e : entries_) {
    kata_humanoid_rig_destroy(e->pending.exchange(nullptr));
    kata_humanoid_rig_destroy(e->rig);
  }
  kata_context_destroy(context_);
}

VmcStreams::Entry* VmcStreams::find(uint64_t stream_id) {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), stream_id,
                             [](const std::unique_ptr<Entry>& e, uint64_t id) { return e->target.stream_id < id; });
  return it != entries_.end() && (*it)->target.stream_id == stream_id ? it->get() : nullptr;
}

void VmcStreams::open(uint64_t stream_id, kata_stream stream) {
  Entry* e = find(stream_id);
  if (!e) return;
  kata_humanoid_rig rig = nullptr;
  if (kata_humanoid_rig_create_for_stream(context_, stream, nullptr, &rig) != KATA_OK) {
    std::fprintf(stderr, "kata serve: [vmc] stream %llu (%s): no humanoid rig: %s; its frames are not sent\n",
                 static_cast<unsigned long long>(stream_id), e->target.where.c_str(), kata_context_last_error(context_));
    rig = nullptr;
  } else if (!e->ghost_address.empty() && kata_humanoid_rig_ghost_joint_count(rig) == 0) {
    std::fprintf(stderr, "kata serve: [vmc] stream %llu (%s): the stream has no ghost (no teacher, or ghost = false, "
                         "or no rest pose in its definition): only its student is sent\n",
                 static_cast<unsigned long long>(stream_id), e->target.where.c_str());
  }
  // A rig the sender never took (a second definition before the first frame) is released here.
  kata_humanoid_rig_destroy(e->pending.exchange(rig, std::memory_order_acq_rel));
}

void VmcStreams::offer(uint64_t stream_id, bool ghost, double time, const float* xyz, uint32_t joints) {
  Entry* e = find(stream_id);
  if (!e || (ghost ? e->ghost_address : e->student_address).empty()) return;
  e->offered.fetch_add(1, std::memory_order_relaxed);
  // Thinned to the rate by the frames' own clock (a time going back is a restart: sent).
  std::atomic<double>& last = ghost ? e->last_ghost : e->last_student;
  std::atomic<bool>& any = ghost ? e->any_ghost : e->any_student;
  if (e->target.rate > 0.0 && any.load(std::memory_order_relaxed)) {
    const double since = time - last.load(std::memory_order_relaxed);
    if (since >= 0.0 && since < 0.999 / e->target.rate) {
      e->thinned.fetch_add(1, std::memory_order_relaxed);
      return;
    }
  }
  if (joints > max_joints_ || stop_.load(std::memory_order_relaxed)) {
    e->dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  // A cell of the bounded multi-producer ring (Vyukov's: per-cell turns, one compare-and-swap).
  uint64_t pos = enqueue_.load(std::memory_order_relaxed);
  Cell* cell = nullptr;
  for (;;) {
    cell = &cells_[pos & mask_];
    const uint64_t turn = cell->turn.load(std::memory_order_acquire);
    const int64_t diff = static_cast<int64_t>(turn - pos);
    if (diff == 0) {
      if (enqueue_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) break;
    } else if (diff < 0) {
      e->dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    } else {
      pos = enqueue_.load(std::memory_order_relaxed);
    }
  }
  last.store(time, std::memory_order_relaxed);
  any.store(true, std::memory_order_relaxed);
  cell->entry = e->index;
  cell->joints = joints;
  cell->ghost = ghost;
  cell->time = time;
  std::memcpy(&xyz_[(pos & mask_) * 3 * max_joints_], xyz, sizeof(float) * 3 * joints);
  cell->turn.store(pos + 1, std::memory_order_release);
  std::atomic_thread_fence(std::memory_order_seq_cst);
  if (sleeping_.load(std::memory_order_relaxed) && sleeping_.exchange(false, std::memory_order_acq_rel))
    wake_.notify_one();
}

void VmcStreams::offer_student(uint64_t stream_id, double time, const float* xyz, uint32_t joints) {
  offer(stream_id, false, time, xyz, joints);
}

void VmcStreams::offer_ghost(uint64_t stream_id, double time, const float* xyz, uint32_t joints) {
  offer(stream_id, true, time, xyz, joints);
}

std::vector<VmcStreams::Counters> VmcStreams::counters() const {
  std::vector<Counters> out;
  for (const auto& e : entries_) {
    Counters c;
    c.stream_id = e->target.stream_id;
    c.offered = e->offered.load();
    c.thinned = e->thinned.load();
    c.dropped = e->dropped.load();
    c.sent = e->sent.load();
    c.send_failed = e->send_failed.load();
    c.pose_failed = e->pose_failed.load();
    out.push_back(c);
  }
  return out;
}

void VmcStreams::send(Entry& e, const Cell& c, const float* xyz, std::vector<unsigned char>& buffer) {
  if (kata_humanoid_rig fresh = e.pending.exchange(nullptr, std::memory_order_acq_rel)) {
    kata_humanoid_rig_destroy(e.rig);
    e.rig = fresh;
  }
  kata_humanoid_pose pose;
  pose.struct_size = sizeof pose;
  const kata_status posed =
      !e.rig ? KATA_E_STATE
      : c.ghost ? kata_humanoid_rig_pose_ghost(e.rig, xyz, c.joints, KATA_HUMANOID_RIGHT_HANDED, &pose)
                : kata_humanoid_rig_pose(e.rig, xyz, c.joints, KATA_HUMANOID_RIGHT_HANDED, &pose);
  size_t size = 0;
  if (posed != KATA_OK || kata_vmc_write_pose(&pose, c.time, 1.0f, buffer.data(), buffer.size(), &size) != KATA_OK) {
    e.pose_failed.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::vector<unsigned char>& to = c.ghost ? e.ghost_address : e.student_address;
  const ssize_t n = sendto(fd_, buffer.data(), size, MSG_DONTWAIT | MSG_NOSIGNAL,
                           reinterpret_cast<const sockaddr*>(to.data()), static_cast<socklen_t>(to.size()));
  (n == static_cast<ssize_t>(size) ? e.sent : e.send_failed).fetch_add(1, std::memory_order_relaxed);
}

void VmcStreams::run() {
  std::vector<unsigned char> buffer(8192);  // a bundle of every bone is under 2 KiB (kata/vmc.h)
  for (;;) {
    Cell& c = cells_[dequeue_ & mask_];
    if (c.turn.load(std::memory_order_acquire) != dequeue_ + 1) {
      if (stop_.load(std::memory_order_acquire)) return;
      std::unique_lock<std::mutex> lock(wake_mutex_);
      sleeping_.store(true, std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_seq_cst);
      if (c.turn.load(std::memory_order_acquire) != dequeue_ + 1)  // a producer that missed the flag: 5 ms at most
        wake_.wait_for(lock, std::chrono::milliseconds(5));
      sleeping_.store(false, std::memory_order_relaxed);
      continue;
    }
    send(*entries_[c.entry], c, &xyz_[(dequeue_ & mask_) * 3 * max_joints_], buffer);
    c.turn.store(dequeue_ + mask_ + 1, std::memory_order_release);
    ++dequeue_;
  }
}

}  // namespace kata::coach
