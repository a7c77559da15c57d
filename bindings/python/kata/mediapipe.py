"""MediaPipe Pose in, scores out: a recording (or a live feed) of Pose world landmarks scored
against a teacher (a BVH clip, or a landmark recording) through the "mediapipe" layout (kata.h
"Layouts": 33 landmarks, metres, camera axes x right / y down / z away; pelvis, chest, neck and
head synthesised; smoothed by default) and kata_stream_push_confidence with each landmark's
visibility as its confidence. Landmarks that are not a person in metres (pixels) or are upside
down (y-up) raise ValueError naming the likely cause.

    import kata.mediapipe
    r = kata.mediapipe.score(landmarks, timestamps_ms, "teacher.bvh")    # units inferred
    print(r.mean_score, r.scores["score"])

landmarks: a sequence of MediaPipe results (the Pose solution's objects with
.pose_world_landmarks.landmark[i].x/.y/.z/.visibility, or the Pose Landmarker's with
.pose_world_landmarks[0][i]; a frame without a person (None or empty) is skipped), or an array
frames x 33 x 3, 4 or 5 (x, y, z[, visibility[, presence]]); confidence = visibility, or the
smaller of visibility and presence (no channel: fully confident). timestamps: one per frame,
increasing, in time_units: "ms" (MediaPipe's), "s", or "auto" (the default for a recording:
inferred from the median step as the CLI does, 2..1000 Hz; steps that fit neither unit are
refused). Stated units are checked the same way: seconds given as "ms" (or the reverse) raise a
ValueError naming the units instead of scoring nothing."""
import os
from typing import Any, Optional, Sequence, Union

import numpy as np

import kata

LANDMARKS = 33
TIME_UNITS = ("auto", "ms", "s")


def _seconds(timestamps: np.ndarray, time_units: str) -> np.ndarray:
    """timestamps (n,) in time_units as seconds; "auto" inferred (kata_time_units_detect) and
    stated units checked against what the steps fit (a recording of 2..1000 Hz)."""
    if time_units not in TIME_UNITS:
        raise ValueError("time_units must be one of %s, not %r" % (", ".join(TIME_UNITS), time_units))
    fits: Optional[str] = None
    if len(timestamps) >= 2:
        try:
            fits = kata.detect_time_units(timestamps)
        except kata.KataError as e:
            if "frame numbers" in e.message:
                raise ValueError(e.message) from None
            if time_units == "auto":
                raise ValueError("timestamps: the steps between frames fit neither seconds nor milliseconds at "
                                 "2..1000 Hz (%s); state time_units=\"s\" or \"ms\"" % e.message) from None
    if time_units == "auto":
        if fits is None:
            raise ValueError("timestamps: one frame cannot tell seconds from milliseconds; state time_units")
        time_units = fits
    elif fits is not None and fits != time_units:
        step = float(np.median(np.diff(timestamps)))
        raise ValueError("timestamps are in %s (median step %.6g: %.4g Hz if %s), not %s as time_units=%r says; "
                         "pass time_units=%r (or \"auto\")" % (
                             "seconds" if fits == "s" else "milliseconds", step,
                             (1.0 if fits == "s" else 1000.0) / step if step > 0 else float("inf"), fits,
                             "seconds" if time_units == "s" else "milliseconds", time_units, fits))
    return timestamps / 1000.0 if time_units == "ms" else timestamps

__all__ = ["LANDMARKS", "landmarks_array", "Scorer", "Scores", "score"]

#: The largest nose-to-ankles distance of a person in metres (the mediapipe layout's unit), as the
#: C++ loader checks it: landmarks in pixels measure hundreds.
MAX_PERSON_METRES = 3.0


def _check_person(a: np.ndarray) -> None:
    """(frames, 33, 5) landmarks show a person in metres, y down (as kata's loader checks a
    "mediapipe" file): the median nose-to-ankles distance at most MAX_PERSON_METRES, and the nose
    not below the ankles by more than half that. ValueError naming the figure and the likely cause."""
    nose, ankles = a[:, 0, :], 0.5 * (a[:, 27, :] + a[:, 28, :])
    seen = np.isfinite(a[:, [0, 27, 28], :3]).all(axis=(1, 2)) & (a[:, [0, 27, 28], 3:5].min(axis=(1, 2)) >= 0.5)
    if not seen.any():
        return
    body = float(np.median(np.linalg.norm(ankles[seen, :3] - nose[seen, :3], axis=1)))
    if not body <= MAX_PERSON_METRES:
        raise ValueError("landmarks: the body measures %.4g from the nose to the ankles (the median over the frames "
                         "that show them): not a person in metres, which MediaPipe's world landmarks are. Pixel "
                         "coordinates (the image landmarks times the image's width and height)? Give "
                         "pose_world_landmarks" % body)
    below = float(np.median(nose[seen, 1] - ankles[seen, 1]))
    if below > 0.5 * body:
        raise ValueError("landmarks: the body is upside down: the nose is %.3g m below the ankles (the median over "
                         "the frames that show them) in MediaPipe's axes, x right, y down, z away from the camera. "
                         "The landmarks look y-up: negate y and z (MediaPipe's world landmarks have y down)" % below)


def _frame_landmarks(result: Any) -> Optional[Sequence[Any]]:
    """The 33 landmarks of one MediaPipe result object, or None without a person."""
    world = getattr(result, "pose_world_landmarks", result)
    if world is None:
        return None
    if hasattr(world, "landmark"):  # the Pose solution: a NormalizedLandmarkList-like message
        world = world.landmark
    elif len(world) and not hasattr(world[0], "x"):  # the Pose Landmarker: one list per person
        world = world[0]
    return world if len(world) else None


def landmarks_array(landmarks: Any) -> np.ndarray:
    """landmarks (see the module) as a (frames, 33, 5) float32 array x, y, z, visibility, presence;
    frames without a person are NaN (skipped by Scorer.push_many)."""
    if isinstance(landmarks, np.ndarray) and landmarks.dtype != object:
        a = landmarks
        if a.ndim != 3 or a.shape[1] != LANDMARKS or a.shape[2] not in (3, 4, 5):
            raise ValueError("MediaPipe landmarks must be frames x 33 x 3, 4 or 5 (x, y, z[, visibility[, presence]]); "
                             "got shape %s" % (a.shape,))
        out = np.ones((a.shape[0], LANDMARKS, 5), dtype=np.float32)
        out[:, :, :a.shape[2]] = a
        return out
    frames = list(landmarks)
    out = np.full((len(frames), LANDMARKS, 5), np.nan, dtype=np.float32)
    for f, result in enumerate(frames):
        lms = _frame_landmarks(result)
        if lms is None:
            continue
        if len(lms) != LANDMARKS:
            raise ValueError("frame %d: %d landmarks; MediaPipe Pose has 33" % (f, len(lms)))
        for i, lm in enumerate(lms):
            out[f, i] = (lm.x, lm.y, lm.z, getattr(lm, "visibility", 1.0), getattr(lm, "presence", 1.0))
    return out


class Scores:
    """What a Scorer read: results and scores (the same RESULT_DTYPE records) numpy arrays, one per
    frame that gave features; mean_score over the frames with ScoreState.SCORING; lost_frames:
    frames accepted without features (tracking lost)."""

    def __init__(self, results: np.ndarray, scores: np.ndarray, lost_frames: int, skipped_frames: int) -> None:
        self.results = results
        self.scores = scores
        self.lost_frames = lost_frames
        self.skipped_frames = skipped_frames  #: frames without a person (not pushed)
        scoring = (results["scored"] != 0) & (scores["state"] == kata.ScoreState.SCORING)
        self.scored = scores[scoring]
        self.mean_score = float(self.scored["score"].mean()) if len(self.scored) else float("nan")
        #: why nothing was scored ("" when something was): no frames, every frame without a person,
        #: tracking lost, still calibrating, after the teacher ended (mean_score is then NaN)
        self.unscored_reason = "" if len(self.scored) else self._unscored_reason()

    def _unscored_reason(self) -> str:
        states = self.scores["state"] if len(self.scores) else np.zeros(0, dtype=np.int32)
        if not len(self.results) and not self.lost_frames and not self.skipped_frames:
            return "no frames were pushed"
        why = []
        if self.skipped_frames:
            why.append("%d frame(s) without a person (skipped)" % self.skipped_frames)
        if self.lost_frames:
            why.append("%d frame(s) tracking lost (fewer than 13 of the 16 body joints above the visibility "
                       "threshold 0.5)" % self.lost_frames)
        calibrating = int((states == kata.ScoreState.CALIBRATING).sum())
        if calibrating:
            why.append("%d frame(s) calibrating (the first 0.25 s after the start settle the alignment; give a "
                       "longer recording, or check that the timestamps are times, not frame numbers)" % calibrating)
        finished = int((states == kata.ScoreState.TEACHER_FINISHED).sum())
        if finished:
            why.append("%d frame(s) after the teacher clip ended" % finished)
        other = len(self.results) - calibrating - finished - int((states == kata.ScoreState.TRACKING_LOST).sum())
        if other > 0:
            why.append("%d frame(s) without a score" % other)
        return "nothing scored: " + ", ".join(why)

    def __len__(self) -> int:
        return len(self.results)

    def __repr__(self) -> str:
        if not len(self.scored):
            return "Scores(%d results, 0 scored, %d lost: %s)" % (len(self), self.lost_frames, self.unscored_reason)
        return "Scores(%d results, %d scored, mean %.1f, %d lost)" % (len(self), len(self.scored), self.mean_score,
                                                                     self.lost_frames)


class Scorer:
    """A MediaPipe stream with a teacher attached: push landmarks (live or a recording), read
    scores. teacher: a BVH path or a kata.Clip, or a landmark recording (a .npy / .csv path, read
    as Context.load_landmarks reads it, with teacher_fps when it has no timestamps, or a
    kata.Landmarks); model: a .kata path (default: the shipped one); first_frame: the teacher's
    first frame (1 skips a CMU clip's T-pose); teacher_layout: the teacher's layout (default "cmu"
    for a BVH, "mediapipe" for a landmark recording). Owns its context; close() or a with block
    releases it. One thread at a time."""

    def __init__(self, teacher: Union[str, "os.PathLike[str]", kata.Clip, kata.Landmarks], model: Optional[str] = None,
                 first_frame: int = 0, teacher_layout: Optional[str] = None, smoothing: bool = True,
                 result_capacity: int = 1024, time_units: str = "ms", teacher_fps: float = 0.0) -> None:
        self._ctx = kata.Context()
        self._model = self._ctx.load_model(model or kata.default_model_path())
        path = "" if isinstance(teacher, (kata.Clip, kata.Landmarks)) else os.fspath(teacher)
        landmark_teacher = isinstance(teacher, kata.Landmarks) or os.path.splitext(path)[1].lower() in (".npy", ".csv")
        with self._ctx.create_layout("mediapipe") as skeleton:
            self.stream = self._ctx.open_stream(skeleton, layout="mediapipe", stencil=self._model.stencil,
                                                result_capacity=result_capacity)
        if not smoothing:
            self.stream.set_smoothing(False)
        if landmark_teacher:
            layout = teacher_layout or "mediapipe"
            lm = teacher if isinstance(teacher, kata.Landmarks) else self._ctx.load_landmarks(path, layout,
                                                                                              fps=teacher_fps)
            with self._ctx.create_layout(layout) as teacher_skeleton:
                self.stream.attach_teacher(self._model, skeleton=teacher_skeleton, positions=lm.positions,
                                           frame_time=lm.frame_time, layout=layout, first_frame=first_frame,
                                           ghost=False)
            if lm is not teacher:
                lm.close()
        else:
            clip = teacher if isinstance(teacher, kata.Clip) else self._ctx.load_clip(path)
            self.stream.attach_teacher(self._model, clip=clip, layout=teacher_layout or "cmu",
                                       first_frame=first_frame, ghost=False)
            if clip is not teacher:
                clip.close()
        self._buffer = self.stream.result_buffer(result_capacity, ghosts=False)
        self._results: list = []
        self._scores: list = []
        self.skipped_frames = 0
        if time_units not in ("ms", "s"):
            raise ValueError('time_units of a live Scorer: "ms" (MediaPipe\'s) or "s", not %r' % (time_units,))
        self.time_units = time_units  #: what push's timestamps are in (push_many may say otherwise)
        self._last_time: Optional[float] = None
        self._person_checked = False  # the first frame with a person is checked (_check_person)

    def push(self, landmarks: Any, timestamp: float) -> kata.Status:
        """One frame: a MediaPipe result object or a (33, 3..5) array, at timestamp in the Scorer's
        time_units ("ms" unless told). Status.OK or Status.TRACKING_LOST; a frame without a person
        is skipped (Status.NO_DATA). A step between frames that no camera makes in those units
        (above 1000 Hz) raises ValueError naming the units."""
        a = landmarks_array(np.asarray(landmarks, dtype=np.float32)[None] if isinstance(landmarks, np.ndarray)
                            else [landmarks])[0]
        if np.isnan(a[:, 0]).all():
            self.skipped_frames += 1
            return kata.Status.NO_DATA
        if not self._person_checked:
            _check_person(a[None])
            self._person_checked = True
        seconds = float(timestamp) / (1000.0 if self.time_units == "ms" else 1.0)
        if self._last_time is not None and 0 < seconds - self._last_time < 0.001:
            step = float(timestamp) - self._last_time * (1000.0 if self.time_units == "ms" else 1.0)
            hint = ("these look like seconds: make the Scorer with time_units=\"s\"" if self.time_units == "ms"
                    else "no camera runs above 1000 Hz")
            raise ValueError("timestamp %r: a step of %.6g %s (%.0f Hz) since the previous frame; %s"
                             % (timestamp, step, self.time_units, 1.0 / (seconds - self._last_time), hint))
        status = self.stream.push(seconds, a[:, :3], np.minimum(a[:, 3], a[:, 4]))
        self._last_time = seconds
        self._drain_if_full()
        return status

    def push_many(self, landmarks: Any, timestamps: Any, time_units: str = "auto") -> int:
        """A recording (see the module): frames without a person are skipped; returns the frames
        pushed. time_units: "auto" (inferred), "ms" or "s" (checked). Reads results as it goes, so
        any length fits."""
        a = landmarks_array(landmarks)
        t = np.asarray(timestamps, dtype=np.float64)
        if t.shape != (len(a),):
            raise ValueError("timestamps: one per frame (%d), got shape %s" % (len(a), t.shape))
        t = _seconds(t, time_units)
        present = ~np.isnan(a[:, :, 0]).all(axis=1)
        self.skipped_frames += int((~present).sum())
        a, t = a[present], t[present]
        _check_person(a)
        self._person_checked = self._person_checked or len(a) > 0
        positions = np.ascontiguousarray(a[:, :, :3])
        confidences = np.ascontiguousarray(np.minimum(a[:, :, 3], a[:, :, 4]))
        chunk = max(self._buffer.capacity // 2, 1)
        for start in range(0, len(a), chunk):
            self.stream.push_many(t[start:start + chunk], positions[start:start + chunk],
                                  confidences[start:start + chunk])
            self._drain()
        if len(t):
            self._last_time = float(t[-1])
        return len(a)

    def _drain_if_full(self) -> None:
        if self.stream.results_pending >= self._buffer.capacity // 2:
            self._drain()

    def _drain(self) -> None:
        r = self.stream.read_results(self._buffer)
        if len(r) and r.scores is not None:
            self._results.append(r.results.copy())
            self._scores.append(r.scores.copy())

    def read(self) -> Scores:
        """Every result since the last read, as Scores."""
        self._drain()
        results = np.concatenate(self._results) if self._results else np.zeros(0, dtype=kata.RESULT_DTYPE)
        scores = np.concatenate(self._scores) if self._scores else np.zeros(0, dtype=kata.RESULT_DTYPE)
        self._results, self._scores = [], []
        return Scores(results, scores, self.stream.lost_frames, self.skipped_frames)

    def close(self) -> None:
        self._ctx.close()

    def __enter__(self) -> "Scorer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def score(landmarks: Any, timestamps: Any, teacher: Union[str, "os.PathLike[str]"], model: Optional[str] = None,
          first_frame: int = 0, teacher_layout: Optional[str] = None, time_units: str = "auto",
          teacher_fps: float = 0.0) -> Scores:
    """Scores a MediaPipe recording (see the module) against a teacher (a BVH clip or a landmark
    recording, as Scorer takes it): a Scorer, every frame pushed, every result read. time_units:
    "auto" (inferred from the steps), "ms" or "s"."""
    with Scorer(teacher, model, first_frame=first_frame, teacher_layout=teacher_layout,
                teacher_fps=teacher_fps) as s:
        s.push_many(landmarks, timestamps, time_units)
        return s.read()
