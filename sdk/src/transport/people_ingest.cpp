// The ingest's path for people frames (schemas/people_frame.fbs): its own verifier, then the
// table's rules as a frame of the group stream (owner, sequence, age, joint count), then on to
// the receiver, which tracks the people and judges each pose.
#include <algorithm>
#include <cmath>

#include "transport/zmq_io.hpp"

namespace kata::transport {

void Ingest::handle_people(const void* data, size_t size, SenderToken sender, int64_t now_ns) {
  PeopleFrameView f;
  const DecodeError e = people_decoder_.decode(data, size, &f);
  if (e != DecodeError::kNone) {
    ++counters_.malformed[static_cast<int>(e)];
    return;
  }
  bool restarted = false;
  if (!admit_frame(sender, f.stream_id, f.sequence, f.capture_ns, f.joints, now_ns, &restarted)) return;
  ++counters_.people_frames;
  counters_.people_poses += static_cast<uint64_t>(f.poses);
  if (handlers_.on_people) handlers_.on_people(f, restarted);
}

}  // namespace kata::transport
