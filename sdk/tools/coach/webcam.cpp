#include "coach/webcam.hpp"

#include "coach/viewer_server.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "coach/lesson.hpp"  // part_name, fail
#include "coach/reps_view.hpp"
#include "coach/vmc_out.hpp"
#include "io/npy.hpp"        // write_npy: the recordings' file format
#include "kata/kata.h"
#include "load_progress.hpp"

namespace kata::coach {

namespace {

constexpr uint32_t kMagic = 0x3143574bu;  // "KWC1"
constexpr uint32_t kPeopleMagic = 0x3150574bu;  // "KWP1"
constexpr size_t kHeaderBytes = 48;
// The frame table is indexed by the page's sequence and keeps every frame for the recordings and
// the report, so the page's number decides how much memory a POST takes: a sequence may run at
// most kMaxSequenceGap ahead of the table (a page drops a few frames, never ten seconds' worth at
// 60 Hz), and a lesson holds at most kMaxFrames (two hours at 30 Hz, about 150 MB of landmarks).
constexpr uint64_t kMaxSequenceGap = 600;
constexpr uint64_t kMaxFrames = 2 * 60 * 60 * 30;
constexpr uint64_t kStudentStream = 2;
// Several people: the streams a lesson opens for the people it meets (a person forgotten by the
// tracker and back later is a new person: their old stream stays, idle, till the end). Beyond
// these, a new person's poses are refused and counted (status "people"."refused_no_stream").
constexpr size_t kMaxPersonStreams = 16;
// The tracker's forget time: long, since a page without a GPU sends a frame every few seconds
// (the tracker's gate widens with the time a person is unseen, so a slow page still matches).
constexpr double kPeopleForgetSeconds = 30.0;

double steady_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

const char* state_text(int32_t state) {
  switch (state) {
    case KATA_SCORE_SCORING: return "tracking";
    case KATA_SCORE_CALIBRATING: return "calibrating";
    case KATA_SCORE_TRACKING_LOST: return "tracking lost";
    case KATA_SCORE_TEACHER_FINISHED: return "teacher finished";
    default: return "tracking lost";
  }
}

// The sidecar timestamps of a landmark .npy, as kata's readers look for them: "X.npy" -> "X.times.npy".
std::string times_path_of(const std::string& npy_path) {
  const bool npy = npy_path.size() >= 4 && npy_path.compare(npy_path.size() - 4, 4, ".npy") == 0;
  return (npy ? npy_path.substr(0, npy_path.size() - 4) : npy_path) + ".times.npy";
}

std::string html_text(const std::string& s) {
  std::string out;
  for (char c : s.substr(0, 64)) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return out;
}

// A header value for an error message: at most 80 printable characters.
std::string header_text(const std::string& value) {
  std::string out;
  for (char c : value.substr(0, 80)) out += (c >= 32 && c < 127) ? c : '?';
  return out.empty() ? "(none)" : out;
}

// The part a person was told to fix most often, "-" for none.
std::string most_fixed(const int (&count)[KATA_PART_COUNT]) {
  int most = 0;
  for (int p = 1; p < KATA_PART_COUNT; ++p)
    if (count[p] > count[most]) most = p;
  return count[most] > 0 ? part_name(most) : "-";
}

}  // namespace

bool parse_webcam_frame(const std::string& body, WebcamFrame* out, std::string* why) {
  if (body.size() < kHeaderBytes) return *why = "shorter than the 48-byte header", false;
  uint32_t magic = 0, count = 0;
  std::memcpy(&magic, body.data(), 4);
  std::memcpy(&count, body.data() + 4, 4);
  if (magic != kMagic) return *why = "bad magic (not a KWC1 frame)", false;
  if (count != 0 && count != kWebcamLandmarks) return *why = "landmark count must be 0 or 33", false;
  if (body.size() != kHeaderBytes + sizeof(float) * kWebcamChannels * count) return *why = "size does not match the landmark count", false;
  double seq = 0;
  std::memcpy(&seq, body.data() + 8, 8);
  std::memcpy(&out->capture_ms, body.data() + 16, 8);
  std::memcpy(&out->landmarks_ms, body.data() + 24, 8);
  if (!(seq >= 0 && seq < 9.0e15) || seq != std::floor(seq)) return *why = "bad sequence", false;
  if (!std::isfinite(out->capture_ms) || !std::isfinite(out->landmarks_ms)) return *why = "non-finite time", false;
  out->sequence = static_cast<uint64_t>(seq);
  out->landmarks = static_cast<int>(count);
  std::memcpy(out->values, body.data() + kHeaderBytes, sizeof(float) * kWebcamChannels * count);
  return true;
}

bool parse_webcam_people_frame(const std::string& body, WebcamPeopleFrame* out, std::string* why) {
  if (body.size() < kHeaderBytes) return *why = "shorter than the 48-byte header", false;
  uint32_t magic = 0, count = 0;
  std::memcpy(&magic, body.data(), 4);
  std::memcpy(&count, body.data() + 4, 4);
  if (magic != kPeopleMagic) return *why = "bad magic (not a KWP1 frame)", false;
  if (count > static_cast<uint32_t>(kMaxPagePoses)) return *why = "more than 16 poses", false;
  if (body.size() != kHeaderBytes + sizeof(float) * kWebcamPoseFloats * count) return *why = "size does not match the pose count", false;
  double seq = 0;
  std::memcpy(&seq, body.data() + 8, 8);
  std::memcpy(&out->capture_ms, body.data() + 16, 8);
  std::memcpy(&out->landmarks_ms, body.data() + 24, 8);
  if (!(seq >= 0 && seq < 9.0e15) || seq != std::floor(seq)) return *why = "bad sequence", false;
  if (!std::isfinite(out->capture_ms) || !std::isfinite(out->landmarks_ms)) return *why = "non-finite time", false;
  out->sequence = static_cast<uint64_t>(seq);
  out->poses = static_cast<int>(count);
  std::memcpy(out->values, body.data() + kHeaderBytes, sizeof(float) * kWebcamPoseFloats * count);
  return true;
}

struct WebcamCoach::Impl {
  WebcamSettings settings;
  bool recording_teacher = false;
  int teacher_frames = 0;
  double teacher_frame_time = 0.0;
  // libkata's handles (released in reverse order by the destructor: the runtime first, since its
  // callback writes here).
  kata_context context = nullptr;
  kata_model model = nullptr;
  kata_skeleton student_skeleton = nullptr;
  // VMC out (--vmc, --vmc-student): the student's landmarks and the ghost's 16 GPD joints (MediaPipe's
  // axes), offered from the result callback; released after the runtime (whose thread offers).
  std::unique_ptr<VmcOut> vmc;
  kata_stream student_stream = nullptr;  // until the runtime owns it
  kata_runtime runtime = nullptr;

  mutable std::mutex mutex;  // frames + events (HTTP threads, the runtime's thread)
  std::condition_variable changed;
  struct Received {
    WebcamFrame frame;
    double received_ms = 0.0;
    bool pushed = false, answered = false;
  };
  std::vector<Received> frames;       // by sequence (the page's); a gap stays unpushed
  std::vector<std::string> events;    // "result" events in order of emission
  std::vector<kata_repetition> repetitions;  // every repetition that ended (on_repetition), bounded
  size_t repetitions_sent = 0;               // of them, those already on an event
  struct Scored {
    uint64_t seq;
    double time;  // seconds from the first pushed frame
    std::string state;
    float score;
  };
  std::vector<Scored> timeline;
  double first_time = -1.0, last_time = -1.0;
  uint64_t pushed = 0, not_in_frame = 0, lost = 0, refused = 0, malformed = 0, results = 0;
  uint64_t answered_upto = 0;  // frames below this were answered or passed over
  nlohmann::json latency = nlohmann::json::object();
  bool stopping = false;

  httplib::Server server;
  std::thread thread;

  void check(kata_status status) const {
    if (status != KATA_OK) fail(kata_context_last_error(context));
  }

  // Attaches the teacher (a BVH clip, or a landmark recording) to the student's stream: the whole
  // motion followed by the online alignment, and the ghost across layouts (the teacher's layout
  // onto the page's MediaPipe student), made by the pipeline once the stream has estimated the
  // student's bone lengths: 16 GPD joints in MediaPipe's world axes, as the page draws them.
  void attach_teacher(kata_stream stream) {
    const std::string& path = settings.teacher;
    const bool bvh = path.size() > 4 && path.compare(path.size() - 4, 4, ".bvh") == 0;
    tools::LoadProgress progress(path);  // a line on stderr if loading takes > 1 s
    kata_teacher_desc td;
    kata_teacher_desc_init(&td);
    td.model = model;
    td.ghost = 1;
    td.ghost_across = 1;
    td.alignment_window = settings.window;
    if (!settings.tolerance.empty()) td.tolerance = settings.tolerance.c_str();
    td.on_progress = [](void* user, uint32_t done, uint32_t total) {
      (*static_cast<tools::LoadProgress*>(user))(static_cast<int>(done), static_cast<int>(total));
    };
    td.on_progress_user = &progress;
    const std::string layout = settings.teacher_layout.empty() ? (bvh ? "cmu" : "mediapipe") : settings.teacher_layout;
    td.layout = layout.c_str();
    kata_clip clip = nullptr;
    kata_skeleton skeleton = nullptr;
    kata_landmarks landmarks = nullptr;
    kata_status status = KATA_OK;
    if (bvh) {
      check(kata_clip_load_bvh(context, path.c_str(), &clip));
      const int count = static_cast<int>(kata_clip_frame_count(clip));
      if (settings.first_frame < 0 || settings.first_frame >= count) {
        kata_clip_destroy(clip);
        fail(path + ": --first-frame is past its end");
      }
      td.clip = clip;
      td.first_frame = static_cast<uint32_t>(settings.first_frame);
      teacher_frames = count - settings.first_frame;
      teacher_frame_time = kata_clip_frame_time(clip);
    } else {
      // A landmark recording (--record-teacher's .npy and .times.npy, or a CSV): its timestamps
      // in seconds unless --time-units says otherwise (a slow page's ~1 s steps would read as ms).
      const int32_t units = settings.time_units == "ms" ? KATA_TIME_MILLISECONDS
                            : settings.time_units == "auto" ? -1
                                                            : KATA_TIME_SECONDS;
      check(kata_landmarks_load(context, path.c_str(), layout.c_str(), 0.0, units, &landmarks));
      const kata_status made = kata_skeleton_create_layout(context, layout.c_str(), &skeleton);
      if (made != KATA_OK) {
        kata_landmarks_destroy(landmarks);
        check(made);
      }
      td.skeleton = skeleton;
      td.positions = kata_landmarks_positions(landmarks);
      td.frames = kata_landmarks_frame_count(landmarks);
      td.frame_time = kata_landmarks_frame_time(landmarks);
      teacher_frames = static_cast<int>(td.frames);
      teacher_frame_time = td.frame_time;
    }
    status = kata_stream_attach_teacher(stream, &td);
    const std::string why = status == KATA_OK ? "" : kata_stream_last_error(stream);
    kata_clip_destroy(clip);  // the stream keeps what it needs
    kata_landmarks_destroy(landmarks);
    kata_skeleton_destroy(skeleton);
    if (status != KATA_OK) fail(path + ": " + why);
    if (settings.reps) {  // the repetition: the whole teacher or its seconds [rep_start, rep_end), looped
      int32_t first = 0, last = -1;
      if (settings.rep_start >= 0.0) {
        const int offset = bvh ? settings.first_frame : 0;  // clip frame of teacher frame 0
        first = static_cast<int32_t>(std::ceil(settings.rep_start / teacher_frame_time - 1e-6)) - offset;
        last = static_cast<int32_t>(std::ceil(settings.rep_end / teacher_frame_time - 1e-6)) - 1 - offset;
        if (first < 0 || last < first || last >= teacher_frames)
          fail("--rep-section " + std::to_string(settings.rep_start) + " " + std::to_string(settings.rep_end) +
               " is not a section of " + path);
      }
      if (kata_stream_set_practice_section(stream, first, last, 1) != KATA_OK)
        fail(path + ": " + kata_stream_last_error(stream));
    }
  }

  void on_repetition(const kata_repetition& r) {  // the runtime's thread, after its frame's result
    if (!settings.reps) return;  // only a lesson that counts them (--reps) shows repetitions
    std::lock_guard<std::mutex> lock(mutex);
    if (settings.people > 1) {
      Person* p = person_of_stream(r.stream_id);
      if (p && p->repetitions.size() < 4096) p->repetitions.push_back(r);
      return;
    }
    if (repetitions.size() < 4096) repetitions.push_back(r);  // bounded; rides on the next event
  }

  // A student's stream as `kata score` / `kata features` read a mediapipe file: the layout's map,
  // axes and smoothing, and the model's stencil, so the page's frames score as the file's do.
  kata_stream open_student_stream() {
    kata_stream_desc sd;
    kata_stream_desc_init(&sd);
    sd.layout = "mediapipe";
    sd.result_capacity = 64;
    if (model) sd.stencil = kata_model_stencil(model);
    kata_stream stream = nullptr;
    check(kata_stream_open(context, student_skeleton, &sd, &stream));
    try {
      attach_teacher(stream);
    } catch (...) {
      kata_stream_destroy(stream);
      throw;
    }
    return stream;
  }

  // ---- several people (--people N > 1)
  kata_people people = nullptr;     // who each pose of a frame is
  std::vector<kata_stream> spare;   // streams opened with the teacher at the start, for the first people
  struct Person {
    uint32_t id = 0;       // the tracker's (1, 2, ...: never reused)
    uint64_t stream = 0;   // the runtime's; 0: none could be opened (their poses are counted, not pushed)
    bool open = true;      // false once the tracker forgot them
    uint64_t pushed = 0, refused = 0, results = 0, scored = 0;
    double score_sum = 0.0;
    int fix_count[KATA_PART_COUNT] = {};
    double part_sum[KATA_PART_COUNT] = {};
    std::vector<Scored> timeline;
    std::vector<kata_repetition> repetitions;  // bounded (4096)
    size_t repetitions_sent = 0;
  };
  std::vector<Person> persons;  // in order of appearance, at most kMaxPersonStreams (reserved)
  struct PeopleReceived {
    double capture_ms = 0.0, received_ms = 0.0;
    int poses = 0;
    uint32_t ids[kMaxPagePoses] = {};  // each pose's person (0: refused)
  };
  std::vector<PeopleReceived> people_frames;  // by sequence, as frames
  uint64_t refused_no_stream = 0;             // poses of a person who got no stream
  uint64_t refused_world_non_finite = 0;      // poses with a NaN or infinite world landmark

  Person* person_of_stream(uint64_t stream) {
    for (Person& p : persons)
      if (p.stream == stream && stream != 0) return &p;
    return nullptr;
  }

  // The person with tracker id `id`, their stream opened (a spare one, or a new one) and added
  // to the runtime when they first appear; nullptr past kMaxPersonStreams. [mutex held]
  Person* person_of(uint32_t id) {
    for (Person& p : persons)
      if (p.id == id) return &p;
    if (persons.size() >= kMaxPersonStreams) return nullptr;
    persons.emplace_back();
    Person& p = persons.back();
    p.id = id;
    p.timeline.reserve(30 * 60 * 10);
    kata_stream stream = nullptr;
    if (!spare.empty()) {
      stream = spare.back();
      spare.pop_back();
    } else {
      try {
        stream = open_student_stream();
      } catch (const std::exception& e) {
        std::fprintf(stderr, "webcam: person %u: no stream: %s\n", id, e.what());
        return &p;
      }
    }
    const uint64_t sid = kata_people_stream_id(kStudentStream, id);
    if (kata_runtime_add_stream(runtime, sid, &stream, "mediapipe", 0) == KATA_OK) {
      p.stream = sid;
    } else {
      std::fprintf(stderr, "webcam: person %u: no stream: %s\n", id, kata_context_last_error(context));
      kata_stream_destroy(stream);
    }
    return &p;
  }

  explicit Impl(const WebcamSettings& s) : settings(s), recording_teacher(!s.record_teacher.empty()) {
    try {
      if (s.people < 1 || s.people > kMaxWebcamPeople)
        fail("--people must be 1.." + std::to_string(kMaxWebcamPeople));
      if (s.people > 1 && (recording_teacher || !s.record_student.empty() || !s.vmc.empty() || !s.vmc_student.empty()))
        fail("--people " + std::to_string(s.people) +
             ": --record-teacher, --record-student, --vmc and --vmc-student take one person (--people 1)");
      if (kata_context_create(&context) != KATA_OK) fail("cannot create a kata context");
      check(kata_skeleton_create_layout(context, "mediapipe", &student_skeleton));
      if (s.people > 1) {
        init_people();
        return;
      }
      // The student's stream as `kata score` / `kata features` read a mediapipe file: the layout's
      // map, axes and smoothing, and the model's stencil, so the page's frames score as the file's do.
      kata_stream_desc sd;
      kata_stream_desc_init(&sd);
      sd.layout = "mediapipe";
      sd.result_capacity = 64;
      if (!recording_teacher) {
        check(kata_model_load(context, settings.model.c_str(), &model));
        sd.stencil = kata_model_stencil(model);
      }
      check(kata_stream_open(context, student_skeleton, &sd, &student_stream));
      if (!recording_teacher) attach_teacher(student_stream);
      frames.reserve(30 * 60 * 10);  // ten minutes at 30 Hz before the first growth
      events.reserve(30 * 60 * 10);
      kata_runtime_desc rd;
      kata_runtime_desc_init(&rd);
      rd.workers = 1;
      rd.max_streams = 1;
      rd.max_joints = kWebcamLandmarks;
      rd.queue_capacity = 256;
      rd.publish_endpoints = settings.publish.c_str();
      rd.on_result = [](void* self, const kata_result_record* r) { static_cast<Impl*>(self)->on_result(*r); };
      rd.on_repetition = [](void* self, const kata_repetition* r) { static_cast<Impl*>(self)->on_repetition(*r); };
      rd.on_result_user = this;
      repetitions.reserve(4096);
      if (!recording_teacher && (!s.vmc.empty() || !s.vmc_student.empty())) {
        kata_skeleton gpd = nullptr;
        check(kata_skeleton_create_layout(context, "gpd", &gpd));
        VmcPerformer student, ghost;
        student.target = s.vmc_student;
        student.skeleton = student_skeleton;
        student.layout = "mediapipe";
        ghost.target = s.vmc;
        ghost.skeleton = gpd;
        ghost.layout = "gpd";
        ghost.up_axis = KATA_UP_Y_DOWN;  // the ghost comes in MediaPipe's world axes, as the page draws it
        try {
          vmc = std::make_unique<VmcOut>(context, student, ghost);
        } catch (...) {
          kata_skeleton_destroy(gpd);
          throw;
        }
        kata_skeleton_destroy(gpd);
      }
      check(kata_runtime_create(context, &rd, &runtime));
      check(kata_runtime_add_stream(runtime, kStudentStream, &student_stream, "mediapipe", 0));
    } catch (...) {
      release();
      throw;
    }
  }
  ~Impl() { release(); }

  // --people N: the model, N streams with the teacher (the first N people's: opened now, not
  // while a frame waits), the tracker (poses in image pixels, MediaPipe's 33 landmarks), the runtime.
  void init_people() {
    check(kata_model_load(context, settings.model.c_str(), &model));
    for (int k = 0; k < settings.people; ++k) spare.push_back(open_student_stream());
    std::reverse(spare.begin(), spare.end());
    kata_people_desc pd;
    kata_people_desc_init(&pd);
    pd.joint_count = kWebcamLandmarks;
    pd.max_people = static_cast<uint32_t>(settings.people);
    pd.max_poses = static_cast<uint32_t>(kMaxPagePoses);
    pd.forget_seconds = kPeopleForgetSeconds;
    check(kata_people_create(context, &pd, &people));
    persons.reserve(kMaxPersonStreams);
    people_frames.reserve(30 * 60 * 10);
    events.reserve(30 * 60 * 10);
    kata_runtime_desc rd;
    kata_runtime_desc_init(&rd);
    rd.workers = 1;
    rd.max_streams = static_cast<uint32_t>(kMaxPersonStreams);
    rd.max_joints = kWebcamLandmarks;
    rd.queue_capacity = 256;
    rd.publish_endpoints = settings.publish.c_str();
    rd.on_result = [](void* self, const kata_result_record* r) { static_cast<Impl*>(self)->on_result(*r); };
    rd.on_repetition = [](void* self, const kata_repetition* r) { static_cast<Impl*>(self)->on_repetition(*r); };
    rd.on_result_user = this;
    check(kata_runtime_create(context, &rd, &runtime));
  }

  void release() {
    kata_runtime_destroy(runtime);  // stops first: the callback writes into this
    runtime = nullptr;
    for (kata_stream& s : spare) kata_stream_destroy(s);
    spare.clear();
    kata_people_destroy(people);
    people = nullptr;
    vmc.reset();  // sends what the callback queued
    kata_stream_destroy(student_stream);
    student_stream = nullptr;
    kata_skeleton_destroy(student_skeleton);
    student_skeleton = nullptr;
    kata_model_destroy(model);
    model = nullptr;
    kata_context_destroy(context);
    context = nullptr;
  }

  void emit(std::string json) {
    events.push_back(std::move(json));
    changed.notify_all();
  }

  std::string simple_event(uint64_t seq, const char* state, double received_ms) {
    nlohmann::json e = {{"seq", seq}, {"state", state}, {"received_ms", received_ms}, {"result_ms", steady_ms()}};
    return e.dump();
  }

  // Frames below `seq` that were pushed but never answered (the confidence gate held them:
  // no features) are shown as tracking lost. [mutex held]
  void pass_over(uint64_t seq) {
    for (; answered_upto < seq && answered_upto < frames.size(); ++answered_upto) {
      Received& r = frames[answered_upto];
      if (r.pushed && !r.answered) {
        r.answered = true;
        ++lost;
        emit(simple_event(answered_upto, "tracking lost", r.received_ms));
      }
    }
  }

  // A result's event: its state, times and, when scored, the scores, part to fix, cue, matched
  // teacher frame, repetition counter and ghost.
  nlohmann::json result_event(const kata_result_record& f, uint64_t seq, const char* state, double received_ms,
                              double capture_ms) const {
    nlohmann::json e = {{"seq", seq},
                        {"state", state},
                        {"received_ms", received_ms},
                        {"result_ms", static_cast<double>(f.computed_ns) / 1e6},
                        {"published_ms", steady_ms()},
                        {"capture_ms", capture_ms},
                        // seconds from the first pushed frame: the time --record-student writes
                        {"time", capture_ms * 1e-3 - first_time}};
    if (f.scored) {
      e["score"] = f.score;
      e["parts"] = std::vector<float>(std::begin(f.part_scores), std::end(f.part_scores));
      e["fix"] = f.part_to_fix >= 0 ? part_name(f.part_to_fix) : "";
      char cue[64];  // the correction cue's phrase, "" for none
      kata_cue_text(&f, cue, sizeof cue);
      e["cue"] = cue;
      e["matched"] = f.matched_teacher_frame;
      if (KATA_RESULT_HAS(&f, repetition_progress) && f.repetition > 0) {
        e["rep"] = f.repetition;
        e["rep_progress"] = f.repetition_progress;
      }
      if (f.ghost && f.ghost_joint_count == static_cast<uint32_t>(KATA_GPD_JOINTS))
        e["ghost"] = std::vector<float>(f.ghost, f.ghost + 3 * KATA_GPD_JOINTS);
    }
    return e;
  }

  // --people: a person's result, on their own stream. [mutex held]
  void on_person_result(const kata_result_record& f) {
    const uint64_t seq = f.frame_sequence;
    Person* p = person_of_stream(f.stream_id);
    if (!p || seq >= people_frames.size()) return;
    const PeopleReceived& r = people_frames[seq];
    ++results;
    ++p->results;
    const char* state = f.scored ? state_text(f.state) : "calibrating";
    nlohmann::json e = result_event(f, seq, state, r.received_ms, r.capture_ms);
    e["person"] = p->id;
    const bool scored = f.scored && (f.state == KATA_SCORE_SCORING || f.state == KATA_SCORE_TEACHER_FINISHED);
    if (scored) {
      ++p->scored;
      p->score_sum += f.score;
      for (int k = 0; k < KATA_PART_COUNT; ++k) p->part_sum[k] += f.part_scores[k];
      if (f.part_to_fix >= 0 && f.part_to_fix < KATA_PART_COUNT) ++p->fix_count[f.part_to_fix];
    }
    p->timeline.push_back({seq, r.capture_ms * 1e-3 - first_time, state, f.scored ? f.score : 0.0f});
    if (p->repetitions_sent < p->repetitions.size()) {
      std::string reps = "[";
      for (; p->repetitions_sent < p->repetitions.size(); ++p->repetitions_sent)
        reps += (reps.size() > 1 ? "," : "") + repetition_json(p->repetitions[p->repetitions_sent]);
      e["reps"] = nlohmann::json::parse(reps + "]");
    }
    emit(e.dump());
  }

  void on_result(const kata_result_record& f) {  // the runtime's thread
    std::lock_guard<std::mutex> lock(mutex);
    if (settings.people > 1) return on_person_result(f);
    const uint64_t seq = f.frame_sequence;
    if (seq >= frames.size()) return;
    Received& r = frames[seq];
    pass_over(seq);
    r.answered = true;
    ++results;
    const char* state = f.scored ? state_text(f.state) : "calibrating";
    nlohmann::json e = result_event(f, seq, state, r.received_ms, r.frame.capture_ms);
    if (vmc) {
      float xyz[3 * kWebcamLandmarks];
      for (int j = 0; j < kWebcamLandmarks; ++j)
        for (int k = 0; k < 3; ++k) xyz[3 * j + k] = r.frame.values[kWebcamChannels * j + k];
      const bool ghost = f.scored && f.ghost && f.ghost_joint_count == static_cast<uint32_t>(KATA_GPD_JOINTS);
      vmc->offer(r.frame.capture_ms * 1e-3 - first_time, xyz, ghost ? f.ghost : nullptr);
    }
    timeline.push_back({seq, r.frame.capture_ms * 1e-3 - first_time, state, f.scored ? f.score : 0.0f});
    if (repetitions_sent < repetitions.size()) {  // the repetitions that ended since the last event
      std::string reps = "[";
      for (; repetitions_sent < repetitions.size(); ++repetitions_sent)
        reps += (reps.size() > 1 ? "," : "") + repetition_json(repetitions[repetitions_sent]);
      e["reps"] = nlohmann::json::parse(reps + "]");
    }
    emit(e.dump());
    if (seq + 1 > answered_upto) answered_upto = seq + 1;
  }

  // Why a frame's sequence cannot be stored ("" when it can). [mutex held]
  std::string sequence_refusal(uint64_t seq) const {
    if (seq >= kMaxFrames) return "sequence " + std::to_string(seq) + ": a lesson holds at most " + std::to_string(kMaxFrames) + " frames";
    const size_t received = settings.people > 1 ? people_frames.size() : frames.size();
    if (seq > received + kMaxSequenceGap)
      return "sequence " + std::to_string(seq) + " is more than " + std::to_string(kMaxSequenceGap) +
             " frames ahead of the last one (" + std::to_string(received) + " received)";
    return "";
  }

  // [an HTTP thread] Empty when the frame's sequence was refused (*why says why).
  std::string receive(const WebcamFrame& f, std::string* why) {
    std::lock_guard<std::mutex> lock(mutex);
    *why = sequence_refusal(f.sequence);
    if (!why->empty()) {
      ++malformed;
      return "";
    }
    const double received = steady_ms();
    if (f.sequence >= frames.size()) frames.resize(f.sequence + 1);
    Received& r = frames[f.sequence];
    r.frame = f;
    r.received_ms = received;
    if (f.landmarks == 0) {
      ++not_in_frame;
      r.answered = true;
      emit(simple_event(f.sequence, "not in frame", received));
    } else {
      const double t = f.capture_ms * 1e-3;
      float xyz[3 * kWebcamLandmarks], confidence[kWebcamLandmarks];
      for (int j = 0; j < kWebcamLandmarks; ++j) {
        for (int k = 0; k < 3; ++k) xyz[3 * j + k] = f.values[kWebcamChannels * j + k];
        confidence[j] = f.values[kWebcamChannels * j + 3];
      }
      if (t <= last_time) {
        ++refused;  // out of order or repeated: the stream wants increasing times
      } else if (recording_teacher) {
        if (first_time < 0) first_time = t;
        last_time = t;
        r.pushed = r.answered = true;
        ++pushed;
        timeline.push_back({f.sequence, t - first_time, "recording", 0.0f});
        emit(simple_event(f.sequence, "recording", received));
      } else if (kata_runtime_push_confidence(runtime, kStudentStream, f.sequence, t, xyz, confidence, kWebcamLandmarks) == KATA_OK) {
        if (first_time < 0) first_time = t;
        last_time = t;
        r.pushed = true;
        ++pushed;
      } else {
        ++refused;
      }
    }
    nlohmann::json ack = {{"seq", f.sequence}, {"received_ms", received}, {"server_ms", steady_ms()}};
    return ack.dump();
  }

  // [an HTTP thread] --people: every pose of a camera frame to the tracker (on its place in the
  // image), each placed pose's world landmarks to its person's stream. Empty when the frame's
  // sequence was refused (*why says why).
  std::string receive_people(const WebcamPeopleFrame& f, std::string* why) {
    std::lock_guard<std::mutex> lock(mutex);
    *why = sequence_refusal(f.sequence);
    if (!why->empty()) {
      ++malformed;
      return "";
    }
    const double received = steady_ms();
    if (f.sequence >= people_frames.size()) people_frames.resize(f.sequence + 1);
    PeopleReceived& r = people_frames[f.sequence];
    r = PeopleReceived();
    r.capture_ms = f.capture_ms;
    r.received_ms = received;
    r.poses = f.poses;
    const double t = f.capture_ms * 1e-3;
    // The tracker follows each pose's place in the image (its own checks refuse a non-finite
    // place, by cause); a pose whose world landmarks are not finite could not be scored: refused
    // here, before tracking, and counted.
    float place[kMaxPagePoses * kWebcamLandmarks * 3], confidence[kMaxPagePoses * kWebcamLandmarks];
    int of_tracked[kMaxPagePoses];  // tracked pose -> the frame's pose
    uint32_t tracked = 0;
    for (int i = 0; i < f.poses; ++i) {
      bool finite = true;
      for (int v = 0; v < kWebcamLandmarks * kWebcamChannels; ++v) finite = finite && std::isfinite(f.world(i)[v]);
      if (!finite) {
        ++refused_world_non_finite;
        continue;
      }
      for (int j = 0; j < kWebcamLandmarks; ++j) {
        const uint32_t at = tracked * kWebcamLandmarks + static_cast<uint32_t>(j);
        place[3 * at] = f.image(i)[2 * j];
        place[3 * at + 1] = f.image(i)[2 * j + 1];
        place[3 * at + 2] = 0.0f;
        confidence[at] = f.world(i)[kWebcamChannels * j + 3];
      }
      of_tracked[tracked++] = i;
    }
    uint32_t tracked_ids[kMaxPagePoses] = {}, ids[kMaxPagePoses] = {};
    if (t <= last_time) {
      ++refused;  // out of order or repeated: the streams want increasing times
    } else if (kata_people_track(people, t, place, confidence, tracked, tracked_ids, kMaxPagePoses) != KATA_OK) {
      ++refused;
    } else {
      for (uint32_t k = 0; k < tracked; ++k) ids[of_tracked[k]] = tracked_ids[k];
      if (first_time < 0) first_time = t;
      last_time = t;
      uint32_t closed[kMaxPagePoses * 4], closed_count = 0;
      if (kata_people_closed(people, closed, sizeof closed / sizeof *closed, &closed_count) == KATA_OK)
        for (uint32_t c = 0; c < closed_count; ++c)
          for (Person& p : persons)
            if (p.id == closed[c]) p.open = false;
      if (f.poses == 0) {
        ++not_in_frame;
        emit(simple_event(f.sequence, "not in frame", received));
      }
      for (int i = 0; i < f.poses; ++i) {
        if (ids[i] == 0) continue;  // refused by the tracker: counted there, by cause
        Person* p = person_of(ids[i]);
        if (!p || p->stream == 0) {
          ++refused_no_stream;
          continue;
        }
        float xyz[3 * kWebcamLandmarks], conf[kWebcamLandmarks];
        for (int j = 0; j < kWebcamLandmarks; ++j) {
          for (int k = 0; k < 3; ++k) xyz[3 * j + k] = f.world(i)[kWebcamChannels * j + k];
          conf[j] = f.world(i)[kWebcamChannels * j + 3];
        }
        if (kata_runtime_push_confidence(runtime, p->stream, f.sequence, t, xyz, conf, kWebcamLandmarks) == KATA_OK) {
          ++pushed;
          ++p->pushed;
          r.ids[i] = ids[i];
        } else {
          ++refused;
          ++p->refused;
        }
      }
    }
    nlohmann::json ack = {{"seq", f.sequence}, {"received_ms", received}, {"server_ms", steady_ms()},
                          {"people", std::vector<uint32_t>(r.ids, r.ids + f.poses)}};
    return ack.dump();
  }

  // --people: the tracker's counters and each person's, for /webcam/status. [mutex held]
  nlohmann::json people_status() const {
    kata_people_counters c;
    c.struct_size = sizeof c;
    nlohmann::json j = nlohmann::json::object();
    if (kata_people_get_counters(people, &c) == KATA_OK)
      j = {{"frames", c.frames},
           {"empty_frames", c.empty_frames},
           {"refused_frames", c.refused_frames},
           {"poses", c.poses},
           {"assigned", c.assigned},
           {"opened", c.opened},
           {"closed", c.closed},
           {"open_streams", c.open_streams},
           {"refused_non_finite", c.refused_non_finite},
           {"refused_out_of_range", c.refused_out_of_range},
           {"refused_few_joints", c.refused_few_joints},
           {"refused_too_many_poses", c.refused_too_many_poses},
           {"refused_table_full", c.refused_table_full}};
    j["refused_no_stream"] = refused_no_stream;
    j["refused_world_non_finite"] = refused_world_non_finite;
    nlohmann::json list = nlohmann::json::array();
    for (const Person& p : persons)
      list.push_back({{"id", p.id}, {"stream", p.stream}, {"open", p.open}, {"pushed", p.pushed},
                      {"results", p.results}, {"scored", p.scored}, {"refused", p.refused},
                      {"mean_score", p.scored ? p.score_sum / static_cast<double>(p.scored) : 0.0},
                      {"repetitions", p.repetitions.size()}});
    j["persons"] = list;
    return j;
  }

  // --people: the class's report: a summary row per person, then a section per person (their
  // score over time, their repetitions), then the page's latency per stage.
  void write_people_report(std::ostream& out) const {
    static const char* const kColours[] = {"#e17055", "#0984e3", "#00b894", "#fdcb6e", "#6c5ce7", "#e84393"};
    out << "<!doctype html><html><head><meta charset=\"utf-8\"><title>kata webcam lesson</title>"
           "<style>body{font:14px sans-serif;margin:2em;max-width:60em}td,th{padding:2px 10px;text-align:right}"
           "svg{background:#f4f4f4}.repplots{display:flex;gap:10px;flex-wrap:wrap}.repplot{background:none}"
           ".repplot .t{font-size:12px;font-weight:600}.repplot .a{font-size:10px;fill:#636e72}.repplot .g{stroke:#ddd}"
           ".repplot .b{fill:#0984e3}.repplot .p{fill:#b2bec3}.repplot .r{stroke:#d63031;stroke-dasharray:4 3}</style>"
           "</head><body><h1>kata webcam lesson</h1>";
    out << "<p>Teacher: " << settings.teacher << "; MediaPipe Pose model complexity " << settings.complexity
        << "; up to " << settings.people << " people (MoveNet MultiPose, then MediaPipe Pose on each person).</p>";
    out << "<p>" << people_frames.size() << " frames received, " << pushed << " poses pushed, " << not_in_frame
        << " frames with nobody, " << refused << " refused; " << persons.size() << " people seen.</p>";
    out << "<h2>People</h2><table class=\"people\"><tr><th>person</th><th>frames</th><th>scored</th><th>mean score</th>";
    if (settings.reps) out << "<th>repetitions</th>";
    out << "<th>part to fix</th>";
    for (int k = 0; k < KATA_PART_COUNT; ++k) out << "<th>" << part_name(k) << "</th>";
    out << "</tr>";
    for (const Person& p : persons) {
      const double n = static_cast<double>(std::max<uint64_t>(p.scored, 1));
      out << "<tr class=\"person\" data-person=\"" << p.id << "\"><td style=\"text-align:left;color:"
          << kColours[(p.id - 1) % 6] << "\">person " << p.id << "</td><td>" << p.pushed << "</td><td>" << p.scored
          << "</td><td>" << (p.scored ? p.score_sum / n : 0.0) << "</td>";
      if (settings.reps) out << "<td>" << p.repetitions.size() << "</td>";
      out << "<td>" << most_fixed(p.fix_count) << "</td>";
      for (int k = 0; k < KATA_PART_COUNT; ++k) out << "<td>" << (p.scored ? p.part_sum[k] / n : 0.0) << "</td>";
      out << "</tr>";
    }
    out << "</table><p>Mean scores over each person's scored frames; the part to fix is the one named most often.</p>";
    const double span = std::max(1e-3, last_time - std::max(first_time, 0.0));
    for (const Person& p : persons) {
      out << "<section class=\"person\" data-person=\"" << p.id << "\"><h2 style=\"color:" << kColours[(p.id - 1) % 6]
          << "\">Person " << p.id << "</h2><p>" << p.pushed << " frames, " << p.scored << " scored, mean score "
          << (p.scored ? p.score_sum / static_cast<double>(p.scored) : 0.0) << ", part to fix most often "
          << most_fixed(p.fix_count) << (p.stream == 0 ? "; no stream could be opened for this person" : "")
          << ".</p><svg width=\"800\" height=\"160\" viewBox=\"0 0 800 200\"><polyline fill=\"none\" stroke=\""
          << kColours[(p.id - 1) % 6] << "\" stroke-width=\"2\" points=\"";
      for (const auto& s : p.timeline)
        if (s.state == "tracking" || s.state == "teacher finished") out << 800.0 * s.time / span << "," << 200.0 - 2.0 * s.score << " ";
      out << "\"/></svg>";
      if (!p.repetitions.empty()) out << "<h3>Repetitions</h3>" << repetitions_report_html(p.repetitions);
      out << "</section>";
    }
    write_latency_html(out);
    out << "</body></html>\n";
  }

  void write_latency_html(std::ostream& out) const {
    out << "<h2>Latency per stage</h2>";
    if (latency.contains("stages") && latency["stages"].is_object()) {
      out << "<table><tr><th>stage</th><th>p50 ms</th><th>p95 ms</th></tr>";
      for (const auto& [name, v] : latency["stages"].items())
        if (v.is_array() && v.size() == 2 && v[0].is_number() && v[1].is_number())
          out << "<tr><td style=\"text-align:left\">" << html_text(name) << "</td><td>" << v[0].get<double>()
              << "</td><td>" << v[1].get<double>() << "</td></tr>";
      out << "</table><p>Measured on the page over " << latency.value("frames", 0)
          << " frames (the page's clock; kata's receive and result times mapped onto it by the POST round trip).</p>";
    } else {
      out << "<p>No latency figures arrived from the page.</p>";
    }
  }

  void write_landmarks(const std::string& path) const {
    std::vector<float> values;
    std::vector<double> times;
    for (const Received& r : frames)
      if (r.pushed) {
        values.insert(values.end(), r.frame.values, r.frame.values + kWebcamLandmarks * kWebcamChannels);
        times.push_back(r.frame.capture_ms * 1e-3 - first_time);
      }
    if (times.empty()) fail(path + ": no frame with a person was received: nothing to record");
    write_npy(path, values.data(), {times.size(), static_cast<size_t>(kWebcamLandmarks), static_cast<size_t>(kWebcamChannels)});
    write_npy(times_path_of(path), times.data(), {times.size()});
  }
};

WebcamCoach::WebcamCoach(const WebcamSettings& settings, const std::string& static_dir, const std::string& host, int port)
    : impl_(std::make_unique<Impl>(settings)) {
  Impl& m = *impl_;
  if (!std::ifstream(static_dir + "/webcam.html") || !std::ifstream(static_dir + "/vendor/mediapipe/pose/pose.js"))
    fail(static_dir + ": the webcam page or MediaPipe Pose is missing (build the kata_viewer target, "
                                             "or give --viewer-dir)");
  if (settings.people > 1 &&
      (!std::ifstream(static_dir + "/vendor/tfjs/tf.min.js") || !std::ifstream(static_dir + "/vendor/movenet/movenet-multipose.json")))
    fail(static_dir + ": --people needs TensorFlow.js and MoveNet MultiPose (vendor/tfjs, vendor/movenet), which are "
                      "missing (build the kata_viewer target, or give --viewer-dir)");
  if (!m.server.set_mount_point("/", static_dir)) fail(static_dir + ": cannot serve this directory");
  m.server.set_file_extension_and_mimetype_mapping("wasm", "application/wasm");
  m.server.set_file_extension_and_mimetype_mapping("tflite", "application/octet-stream");
  m.server.set_file_extension_and_mimetype_mapping("binarypb", "application/octet-stream");
  m.server.set_file_extension_and_mimetype_mapping("data", "application/octet-stream");
  m.server.set_file_extension_and_mimetype_mapping("bin", "application/octet-stream");  // MoveNet's weights
  // Any page open in the user's browser can send a "simple" cross-origin POST to 127.0.0.1 without
  // a preflight, and a DNS-rebinding page can even read the answers: only requests addressed to
  // this server by its own name (Host) and coming from its own page (Origin, when the browser
  // sends one) are served. The port is known only after binding, hence read at request time.
  m.server.set_pre_routing_handler([this, host](const httplib::Request& req, httplib::Response& res) {
    const std::string own_port = std::to_string(port_);
    auto own = [&](const std::string& authority) {
      return authority == "127.0.0.1:" + own_port || authority == "localhost:" + own_port || authority == host + ":" + own_port ||
             authority == "[::1]:" + own_port;
    };
    const std::string origin = req.get_header_value("Origin");
    const std::string scheme = "http://";
    const bool origin_ok = !req.has_header("Origin") ||
                           (origin.compare(0, scheme.size(), scheme) == 0 && own(origin.substr(scheme.size())));
    if (own(req.get_header_value("Host")) && origin_ok) return httplib::Server::HandlerResponse::Unhandled;
    res.status = 403;
    res.set_content("kata coach serves only its own page (Host " + header_text(req.get_header_value("Host")) +
                        ", Origin " + header_text(origin) + " refused)",
                    "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  m.server.Get("/", [](const httplib::Request&, httplib::Response& res) { res.set_redirect("/webcam.html"); });
  m.server.Get("/webcam/setup", [this](const httplib::Request&, httplib::Response& res) {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const Impl& i = *impl_;
    // A page (re)loaded into a running lesson continues it: its numbering after the frames kata
    // has, its capture times after the last one (a reloaded page's clock starts again at 0).
    nlohmann::json j = {{"next_seq", i.frames.size()},
                        {"last_capture_ms", i.last_time >= 0 ? i.last_time * 1e3 : -1.0},
                        {"mode", i.recording_teacher ? "record-teacher" : "lesson"},
                        {"teacher", i.recording_teacher ? "" : i.settings.teacher},
                        {"teacher_frames", i.teacher_frames},
                        {"teacher_frame_time", i.teacher_frame_time},
                        {"complexity", i.settings.complexity},
                        {"people", i.settings.people},
                        {"parts", std::vector<std::string>{part_name(0), part_name(1), part_name(2), part_name(3),
                                                           part_name(4)}}};
    res.set_content(j.dump(), "application/json");
  });
  m.server.Post("/webcam/frame", [this](const httplib::Request& req, httplib::Response& res) {
    if (impl_->settings.people > 1) {
      auto f = std::make_unique<WebcamPeopleFrame>();  // 12 KB: not on an HTTP thread's stack
      std::string why;
      if (!parse_webcam_people_frame(req.body, f.get(), &why)) {
        {
          std::lock_guard<std::mutex> lock(impl_->mutex);
          ++impl_->malformed;
        }
        res.status = 400;
        res.set_content("malformed frame: " + why, "text/plain");
        return;
      }
      std::string ack = impl_->receive_people(*f, &why);
      if (ack.empty()) {
        res.status = 400;
        res.set_content("frame refused: " + why, "text/plain");
        return;
      }
      res.set_content(ack, "application/json");
      return;
    }
    WebcamFrame f;
    std::string why;
    if (!parse_webcam_frame(req.body, &f, &why)) {
      {
        std::lock_guard<std::mutex> lock(impl_->mutex);
        ++impl_->malformed;
      }
      res.status = 400;
      res.set_content("malformed frame: " + why, "text/plain");
      return;
    }
    std::string ack = impl_->receive(f, &why);
    if (ack.empty()) {
      res.status = 400;
      res.set_content("frame refused: " + why, "text/plain");
      return;
    }
    res.set_content(ack, "application/json");
  });
  m.server.Post("/webcam/latency", [this](const httplib::Request& req, httplib::Response& res) {
    nlohmann::json j = nlohmann::json::parse(req.body, nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
      res.status = 400;
      return;
    }
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->latency = std::move(j);
    res.set_content("{}", "application/json");
  });
  m.server.Get("/webcam/status", [this](const httplib::Request&, httplib::Response& res) {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    const Impl& i = *impl_;
    nlohmann::json j = {{"frames", i.frames.size()}, {"results", i.results}, {"pushed", i.pushed},
                        {"not_in_frame", i.not_in_frame}, {"lost", i.lost}, {"refused", i.refused},
                        {"malformed", i.malformed}, {"events", i.events.size()}};
    if (i.settings.people > 1) {
      j["frames"] = i.people_frames.size();
      j["people"] = i.people_status();
    }
    res.set_content(j.dump(), "application/json");
  });
  m.server.Get("/webcam/events", [this](const httplib::Request& req, httplib::Response& res) {
    size_t first = 0;
    {
      std::lock_guard<std::mutex> lock(impl_->mutex);
      first = impl_->events.size();  // live: from now on (a reconnecting page only needs the newest)
    }
    if (req.has_param("from")) first = std::strtoull(req.get_param_value("from").c_str(), nullptr, 10);
    res.set_header("Cache-Control", "no-cache");
    res.set_chunked_content_provider("text/event-stream", [this, next = first](size_t, httplib::DataSink& sink) mutable {
      std::string out;
      {
        std::unique_lock<std::mutex> lock(impl_->mutex);
        impl_->changed.wait_for(lock, std::chrono::milliseconds(250),
                                [&] { return impl_->stopping || impl_->events.size() > next; });
        if (impl_->stopping) return false;
        for (; next < impl_->events.size(); ++next) out += "event: result\ndata: " + impl_->events[next] + "\n\n";
      }
      if (out.empty()) out = ": keep-alive\n\n";
      return sink.write(out.data(), out.size());
    });
  });
  port_ = port == 0 ? m.server.bind_to_any_port(host) : (m.server.bind_to_port(host, port) ? port : -1);
  if (port_ <= 0) fail(cannot_listen_message("webcam", host, port));
  m.thread = std::thread([this] { impl_->server.listen_after_bind(); });
}

WebcamCoach::~WebcamCoach() {
  try {
    finish();
  } catch (...) {
  }
}

uint64_t WebcamCoach::results() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->results;
}

void WebcamCoach::finish() {
  Impl& m = *impl_;
  if (m.runtime) {
    kata_runtime_stop(m.runtime);  // every pushed frame answered
    std::lock_guard<std::mutex> lock(m.mutex);
    m.pass_over(m.frames.size());
  }
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    if (m.stopping) return;
    m.stopping = true;
  }
  m.changed.notify_all();
  m.server.stop();
  if (m.thread.joinable()) m.thread.join();
  if (!m.settings.record_teacher.empty()) m.write_landmarks(m.settings.record_teacher);
  if (!m.settings.record_student.empty()) m.write_landmarks(m.settings.record_student);
}

std::string WebcamCoach::summary() const {
  const Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  if (m.settings.people > 1) {
    char line[512];
    std::snprintf(line, sizeof line,
                  "webcam (%d people): %zu frames received (%llu poses pushed, %llu not in frame, %llu refused), %llu "
                  "results, %zu people seen",
                  m.settings.people, m.people_frames.size(), static_cast<unsigned long long>(m.pushed),
                  static_cast<unsigned long long>(m.not_in_frame), static_cast<unsigned long long>(m.refused),
                  static_cast<unsigned long long>(m.results), m.persons.size());
    std::string out = line;
    for (const Impl::Person& p : m.persons) {
      std::snprintf(line, sizeof line, "; person %u: %llu frames, %llu scored, mean score %.2f, fix %s", p.id,
                    static_cast<unsigned long long>(p.pushed), static_cast<unsigned long long>(p.scored),
                    p.scored ? p.score_sum / static_cast<double>(p.scored) : 0.0, most_fixed(p.fix_count).c_str());
      out += line;
      if (m.settings.reps) out += ", repetitions " + std::to_string(p.repetitions.size());
    }
    if (m.latency.contains("stages")) out += "; latency per stage (page): " + m.latency["stages"].dump();
    return out;
  }
  double sum = 0;
  int scored = 0;
  for (const auto& s : m.timeline)
    if (s.state == "tracking" || s.state == "teacher finished") sum += s.score, ++scored;
  char line[512];
  std::snprintf(line, sizeof line,
                "webcam: %zu frames received (%llu with a person, %llu not in frame, %llu refused), %llu results, %d "
                "scored, mean score %.2f, %llu tracking lost",
                m.frames.size(), static_cast<unsigned long long>(m.pushed), static_cast<unsigned long long>(m.not_in_frame),
                static_cast<unsigned long long>(m.refused), static_cast<unsigned long long>(m.results), scored,
                scored ? sum / scored : 0.0, static_cast<unsigned long long>(m.lost));
  std::string out = line;
  if (!m.repetitions.empty()) out += "; repetitions: " + repetitions_summary(m.repetitions);
  if (m.latency.contains("stages")) out += "; latency per stage (page): " + m.latency["stages"].dump();
  return out;
}

void WebcamCoach::write_report(const std::string& path) const {
  const Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  std::ofstream out(path);
  if (!out) fail(path + ": cannot open for writing");
  if (m.settings.people > 1) {
    m.write_people_report(out);
    return;
  }
  out << "<!doctype html><html><head><meta charset=\"utf-8\"><title>kata webcam lesson</title>"
         "<style>body{font:14px sans-serif;margin:2em;max-width:60em}td,th{padding:2px 10px;text-align:right}"
         "svg{background:#f4f4f4}</style></head><body><h1>kata webcam lesson</h1>";
  out << "<p>Teacher: " << (m.recording_teacher ? "(recording a teacher)" : m.settings.teacher)
      << "; MediaPipe Pose model complexity " << m.settings.complexity << ".</p>";
  double sum = 0;
  int scored = 0;
  for (const auto& s : m.timeline)
    if (s.state == "tracking" || s.state == "teacher finished") sum += s.score, ++scored;
  out << "<p>" << m.frames.size() << " frames received, " << m.pushed << " with a person, " << m.not_in_frame
      << " not in frame, " << m.lost << " tracking lost; " << scored << " scored, mean score "
      << (scored ? sum / scored : 0.0) << ".</p>";
  // Scores over time (inline SVG).
  const double span = m.timeline.empty() ? 1.0 : std::max(1e-3, m.timeline.back().time);
  out << "<h2>Score over time</h2><svg width=\"800\" height=\"200\" viewBox=\"0 0 800 200\"><polyline fill=\"none\" "
         "stroke=\"#2a7\" stroke-width=\"2\" points=\"";
  for (const auto& s : m.timeline)
    if (s.state == "tracking" || s.state == "teacher finished")
      out << 800.0 * s.time / span << "," << 200.0 - 2.0 * s.score << " ";
  out << "\"/></svg>";
  if (!m.repetitions.empty())
    out << "<h2>Repetitions</h2><style>.repplots{display:flex;gap:10px;flex-wrap:wrap}.repplot{background:none}"
           ".repplot .t{font-size:12px;font-weight:600}.repplot .a{font-size:10px;fill:#636e72}.repplot .g{stroke:#ddd}"
           ".repplot .b{fill:#0984e3}.repplot .p{fill:#b2bec3}.repplot .r{stroke:#d63031;stroke-dasharray:4 3}</style>"
        << repetitions_report_html(m.repetitions);
  m.write_latency_html(out);
  out << "</body></html>\n";
}

}  // namespace kata::coach
