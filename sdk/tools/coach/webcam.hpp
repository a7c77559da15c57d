// `kata coach --webcam`: a webcam is the student (or, with --record-teacher, the teacher).
//
// The page (viewer/webcam.html) runs MediaPipe Pose in the browser and POSTs each camera frame's
// 33 world landmarks with their visibility and its capture time; this side pushes them as a
// "mediapipe"-layout stream through a kata runtime (kata/runtime.h, the teacher attached to the
// stream with kata_stream_attach_teacher: the public C ABI only, as the rest of the coach), and sends every result
// back to the page as a server-sent event, with the ghost: the matched teacher frame's 16 GPD
// joints turned to face the way the student faces, scaled to the student's spine and stood on
// the student's hip, in MediaPipe's world axes (the page projects it over the video). A webcam
// student has no rest pose, so the runtime's own ghost (exact bones, needs one) is not made.
//
// HTTP (cpp-httplib 0.11, Debian 12's libcpp-httplib-dev, which has no WebSocket: plain HTTP/1.1
// keep-alive POSTs up, server-sent events down):
//   GET  /webcam.html, /webcam.js, /vendor/...   the page and MediaPipe's files (node_modules build)
//   GET  /webcam/setup    {"mode": "lesson"|"record-teacher", teacher frames, frame time, ...}
//   POST /webcam/frame    one frame (binary, little-endian, see WebcamFrame) -> {"seq", "received_ms",
//                         "server_ms"}: the server's steady clock (ms) for the page's clock offset
//   GET  /webcam/events   text/event-stream of "result" events (JSON, ids = frame sequence)
//   POST /webcam/latency  the page's latency summary per stage (JSON), kept for the report
//   GET  /webcam/status   {"frames", "results", "pushed", "not_in_frame", "lost", "refused"}
//
// Several people (--people N, 2..4): the page finds the people (MoveNet MultiPose) and each one's
// landmarks (MediaPipe Pose on their crop) and POSTs every pose of a camera frame, unordered and
// unnamed (WebcamPeopleFrame); kata's people tracker (kata/people.h) says who each pose is, on the
// poses' places in the image, and each person's world landmarks go to their own stream with the
// teacher attached. The answer names each pose's person; every result event says its person;
// the report has a section per person. One person (the default) is the single-stream path above.
//
// Threads: httplib's pool calls receive() (one mutex orders the pushes of the one stream: the
// runtime wants one producer per stream); the runtime's thread calls the result callback, which
// takes the same mutex to read the frame it answers. Neither lock is the runtime's. The HTTP side
// allocates per request (httplib does); the runtime's live path does not.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace httplib {
class Server;
}

namespace kata::coach {

struct WebcamSettings {
  std::string model = "models/default.kata";
  std::string teacher = "data/cmu/05_18.bvh";  // a BVH, or landmarks (.npy/.csv, mediapipe layout)
  std::string teacher_layout;                  // "" : cmu for a BVH, mediapipe for landmarks
  std::string time_units = "s";                // of a landmark teacher's timestamps (the coach records seconds;
                                               // a slow page's ~1 s steps would read as ms under auto)
  int first_frame = 1;                         // of a BVH teacher (skips CMU's T-pose)
  double window = 0.5;                         // alignment window, teacher seconds
  std::string tolerance;                       // kata_teacher_desc.tolerance; "" for the default (normal)
  std::string publish = "tcp://127.0.0.1:*";
  std::string record_teacher;                  // record mode: landmarks .npy (+ .times.npy), no scoring
  std::string record_student;                  // a lesson also keeps what the page sent here
  int complexity = 0;                          // MediaPipe model: 0 lite, 1 full, 2 heavy
  // Repetitions (docs/coach/repetitions.md): the teacher (whole, or its seconds rep_start..rep_end,
  // clip time) is one repetition, looped; the page shows the counter, the report the table and plots.
  bool reps = false;
  double rep_start = -1.0, rep_end = -1.0;
  std::string vmc, vmc_student;                // VMC receivers (HOST:PORT) of the ghost / the student
  int people = 1;                              // people coached at once (1..kMaxWebcamPeople)
};

constexpr int kMaxWebcamPeople = 4;

constexpr int kWebcamLandmarks = 33;
constexpr int kWebcamChannels = 4;  // x, y, z (metres, MediaPipe world axes), visibility

// One frame as the page POSTs it: a 48-byte header, then landmarks x 4 float32.
//   uint32 magic "KWC1" (0x3143574b), uint32 landmarks (33, or 0: MediaPipe found nobody),
//   float64 sequence (0, 1, ... per page session), float64 capture_ms, float64 landmarks_ms
//   (the page's performance.now() when the frame was grabbed / MediaPipe answered),
//   float64 reserved x 2.
struct WebcamFrame {
  uint64_t sequence = 0;
  double capture_ms = 0.0, landmarks_ms = 0.0;
  int landmarks = 0;
  float values[kWebcamLandmarks * kWebcamChannels] = {};
};
// Parses a POSTed body; false (and *why) for a malformed one.
bool parse_webcam_frame(const std::string& body, WebcamFrame* out, std::string* why);

// The most poses a people frame may carry (more than --people: the tracker takes the most
// confident --people and counts the rest).
constexpr int kMaxPagePoses = 16;
constexpr int kWebcamPoseFloats = kWebcamLandmarks * (kWebcamChannels + 2);

// One camera frame of several people (--people N): the 48-byte header of WebcamFrame with magic
// "KWP1" (0x3150574b) and the pose count (0..kMaxPagePoses) in place of the landmark count, then
// per pose 33 x 4 float32 (world landmarks and visibility, as WebcamFrame) and 33 x 2 float32 (the
// landmarks' place in the camera image, pixels: the space the tracker follows people in).
struct WebcamPeopleFrame {
  uint64_t sequence = 0;
  double capture_ms = 0.0, landmarks_ms = 0.0;
  int poses = 0;
  float values[kMaxPagePoses * kWebcamPoseFloats] = {};
  const float* world(int pose) const { return values + kWebcamPoseFloats * pose; }
  const float* image(int pose) const { return world(pose) + kWebcamLandmarks * kWebcamChannels; }
};
bool parse_webcam_people_frame(const std::string& body, WebcamPeopleFrame* out, std::string* why);

class WebcamCoach {
 public:
  // Loads the model and the teacher, starts the runtime and the HTTP server on host:port
  // (port 0: any free one) serving `static_dir`. Throws kata::cli::Failure.
  WebcamCoach(const WebcamSettings& settings, const std::string& static_dir, const std::string& host, int port);
  ~WebcamCoach();
  WebcamCoach(const WebcamCoach&) = delete;
  WebcamCoach& operator=(const WebcamCoach&) = delete;

  int port() const { return port_; }
  // Stops the runtime (every pushed frame answered) and the server; writes the recordings.
  void finish();
  // A one-line summary (frames, scored, mean score, latency per stage from the page).
  std::string summary() const;
  // Writes a self-contained HTML report: scores over time, states, the latency per stage.
  void write_report(const std::string& path) const;
  uint64_t results() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

}  // namespace kata::coach
