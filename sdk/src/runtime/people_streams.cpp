// People frames (schemas/people_frame.fbs) in the runtime: each group stream gets a people
// tracker (kata/people.h) at its first people frame; every pose the tracker places goes to its
// person's stream (transport::person_stream_id), opened with the group's definition when the
// person appears and closed when the tracker forgets them or the group closes. All on the I/O
// thread, which owns the ingest; after a group's first frame and a person's opening, a frame
// allocates nothing (the tracker's tables are sized at the group's creation). What becomes of
// every people frame and pose is counted (PeopleCounters) in atomics only the I/O thread writes.
#include "runtime/runtime_internal.hpp"

#include <cstdio>

#include "people/tracker.hpp"

namespace kata::runtime {

struct Runtime::PeopleGroup {
  PeopleGroup(uint64_t group, const transport::SkeletonDefinition& d, const people::TrackerConfig& c)
      : id(group), definition(d), tracker(c), ids(static_cast<size_t>(transport::kMaxPeoplePoses)),
        person(static_cast<size_t>(c.max_people)), stream(static_cast<size_t>(c.max_people)),
        sequence(static_cast<size_t>(c.max_people)) {}
  uint64_t id;
  transport::SkeletonDefinition definition;  // the group's, copied for its persons' streams
  people::Tracker tracker;
  std::vector<uint32_t> ids;      // this frame's pose -> person (0: refused)
  // Persons with an open stream: tracker id, stream id, next frame sequence (max_people slots).
  std::vector<uint32_t> person;
  std::vector<uint64_t> stream;
  std::vector<uint64_t> sequence;
  uint64_t refused_open = 0;  // persons whose stream could not be opened (max_streams): poses dropped
  people::TrackerCounters seen;  // the tracker's counters already added to the runtime's
  bool logged = false;
};

namespace {
// PeopleCounters' fields in the order of Runtime::people_counts_ (the enum below names them).
constexpr uint64_t PeopleCounters::*kPeopleFields[] = {
    &PeopleCounters::frames,           &PeopleCounters::empty_frames,          &PeopleCounters::refused_frames,
    &PeopleCounters::poses,            &PeopleCounters::assigned,              &PeopleCounters::refused_non_finite,
    &PeopleCounters::refused_out_of_range, &PeopleCounters::refused_few_joints, &PeopleCounters::refused_too_many_poses,
    &PeopleCounters::refused_table_full, &PeopleCounters::streams_opened,      &PeopleCounters::streams_closed,
    &PeopleCounters::streams_refused,  &PeopleCounters::unopened};
enum : int {
  kFrames, kEmptyFrames, kRefusedFrames, kPoses, kAssigned, kNonFinite, kOutOfRange, kFewJoints, kTooManyPoses,
  kTableFull, kStreamsOpened, kStreamsClosed, kStreamsRefused, kUnopened, kCounts
};
static_assert(sizeof(kPeopleFields) / sizeof(kPeopleFields[0]) == kCounts, "a PeopleCounters field without its index");
// The tracker's counts the runtime adds up as they are (its opened / closed are the runtime's own:
// a person whose stream cannot be opened is counted apart).
struct FromTracker {
  uint64_t people::TrackerCounters::*from;
  int to;
};
constexpr FromTracker kFromTracker[] = {
    {&people::TrackerCounters::frames, kFrames},
    {&people::TrackerCounters::empty_frames, kEmptyFrames},
    {&people::TrackerCounters::refused_frames, kRefusedFrames},
    {&people::TrackerCounters::poses, kPoses},
    {&people::TrackerCounters::assigned, kAssigned},
    {&people::TrackerCounters::refused_non_finite, kNonFinite},
    {&people::TrackerCounters::refused_out_of_range, kOutOfRange},
    {&people::TrackerCounters::refused_few_joints, kFewJoints},
    {&people::TrackerCounters::refused_too_many_poses, kTooManyPoses},
    {&people::TrackerCounters::refused_table_full, kTableFull}};

// The tracker's settings for a group: its defaults (kata_people_desc_init's), the group's joints.
people::TrackerConfig group_tracker(int joints) {
  people::TrackerConfig c;
  c.joints = joints;
  c.max_poses = transport::kMaxPeoplePoses;
  return c;
}
}  // namespace

void Runtime::push_people(const transport::PeopleFrameView& f, bool restarted) {
  StreamState* s = find(f.stream_id);
  if (!s) {  // the group stream was closed by the app (the ingest still knows it): its people too
    count_people(kRefusedFrames, 1);
    close_people(f.stream_id);
    return;
  }
  PeopleGroup* g = nullptr;
  for (const auto& p : people_groups_)
    if (p->id == f.stream_id) g = p.get();
  if (!g) {
    // One group per live stream at most: the table is bounded by max_streams.
    people_groups_.push_back(std::make_shared<PeopleGroup>(f.stream_id, s->definition, group_tracker(f.joints)));
    g = people_groups_.back().get();
  }
  if (f.joints != g->tracker.joints()) {  // the ingest judged the joint count against the definition
    count_people(kRefusedFrames, 1);
    return;
  }
  const double t = static_cast<double>(f.capture_ns) * 1e-9;
  const people::Frame taken = g->tracker.track(t, f.xyz, f.confidence, f.poses, g->ids.data());
  const people::Tracker& tr = g->tracker;
  for (const FromTracker& m : kFromTracker) {
    const uint64_t n = tr.counters().*m.from - g->seen.*m.from;
    if (n != 0) count_people(m.to, n);
  }
  g->seen = tr.counters();
  if (taken != people::Frame::kTaken) return;
  const size_t slots = g->person.size();
  for (int i = 0; i < tr.closed_count(); ++i) {
    for (size_t k = 0; k < slots; ++k) {
      if (g->person[k] != tr.closed()[i]) continue;
      if (close_stream(g->stream[k])) count_people(kStreamsClosed, 1);
      g->person[k] = 0;
    }
  }
  for (int i = 0; i < tr.opened_count(); ++i) {
    size_t k = 0;
    while (k < slots && g->person[k] != 0) ++k;
    if (k == slots) continue;  // cannot happen: the tracker keeps at most max_people open
    transport::SkeletonDefinition d = g->definition;
    d.stream_id = transport::person_stream_id(g->id, tr.opened()[i]);
    try {
      open_announced(d);
    } catch (const Error& e) {
      count_people(kStreamsRefused, 1);
      ++g->refused_open;
      if (!g->logged) {
        g->logged = true;
        std::fprintf(stderr, "\nkata runtime: group stream %llu: a person's stream cannot be opened: %s; their poses "
                     "are dropped (not logged again)\n", static_cast<unsigned long long>(g->id), e.what());
      }
      continue;
    }
    g->person[k] = tr.opened()[i];
    g->stream[k] = d.stream_id;
    g->sequence[k] = 0;
    count_people(kStreamsOpened, 1);
  }
  for (int i = 0; i < f.poses; ++i) {
    const uint32_t id = g->ids[static_cast<size_t>(i)];
    if (id == 0) continue;
    size_t k = 0;
    while (k < slots && g->person[k] != id) ++k;
    if (k == slots) {  // their stream could not be opened
      count_people(kUnopened, 1);
      continue;
    }
    const size_t at = static_cast<size_t>(i) * static_cast<size_t>(f.joints);
    push(g->stream[k], g->sequence[k]++, t, f.xyz + 3 * at, f.joints, restarted,
         f.confidence ? f.confidence + at : nullptr);
  }
}

void Runtime::close_people(uint64_t group_id) {
  for (size_t i = 0; i < people_groups_.size(); ++i) {
    PeopleGroup& g = *people_groups_[i];
    if (g.id != group_id) continue;
    for (size_t k = 0; k < g.person.size(); ++k)
      if (g.person[k] != 0 && close_stream(g.stream[k])) count_people(kStreamsClosed, 1);
    people_groups_[i] = people_groups_.back();
    people_groups_.pop_back();
    return;
  }
}

void Runtime::count_people(int index, uint64_t n) {
  std::atomic<uint64_t>& c = people_counts_[index];
  c.store(c.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);  // the I/O thread is the only writer
}

PeopleCounters Runtime::people_counters() const {
  static_assert(kCounts == kPeopleCounts, "PeopleCounters and its atomics differ");
  PeopleCounters c;
  for (int i = 0; i < kCounts; ++i) c.*kPeopleFields[i] = people_counts_[i].load(std::memory_order_relaxed);
  return c;
}

}  // namespace kata::runtime
